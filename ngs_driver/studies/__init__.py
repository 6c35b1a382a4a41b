"""Studies over many runs: FEMA P695 record sets (``fema``), intensity measures and scaling
(``im``), lognormal fragility by maximum likelihood (``fragility``), incremental dynamic
analysis on Dask (``ida``) and its command ``dam-seismic ida`` (``cli``). docs/studies.md."""
