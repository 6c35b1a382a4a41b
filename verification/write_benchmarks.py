"""Write BENCHMARKS.md from the pytest-benchmark JSON of `make bench`.

Medians only (this is a shared 2-core machine: absolute times are noisy; ratios are taken
between benchmarks of the same run). Usage: python verification/write_benchmarks.py [json] [md]
"""
from __future__ import annotations

import json
import pathlib
import platform
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _cpu() -> str:
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    src = pathlib.Path(argv[0]) if argv else ROOT / ".benchmarks.json"
    dst = pathlib.Path(argv[1]) if len(argv) > 1 else ROOT / "BENCHMARKS.md"
    data = json.loads(src.read_text())
    rows = {}
    for b in data["benchmarks"]:
        rows[b["name"]] = (b["stats"]["median"], b.get("extra_info", {}), b["stats"]["rounds"])
    out = ["# Benchmarks", "",
           f"Machine: {_cpu()}, {data.get('machine_info', {}).get('cpu', {}).get('count', '?')}"
           f" cores, Python {platform.python_version()}; date {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.",
           "Command: `make bench` (pytest-benchmark medians; then this script).", "",
           "| benchmark | median | rounds | extra |", "|---|---|---|---|"]
    for name, (med, extra, rounds) in sorted(rows.items()):
        unit = f"{med * 1e3:.3f} ms"
        ex = ", ".join(f"{k}={v}" for k, v in extra.items())
        if "points" in extra:
            ex += f", {extra['points'] / med / 1e6:.1f} M points/s"
        out.append(f"| `{name}` | {unit} | {rounds} | {ex} |")
    # derived ratios of the same run
    out += ["", "## Ratios (same run)", ""]
    for th in ("1", "all"):
        k, c = rows.get(f"test_bench_numba[{th}]"), rows.get(f"test_bench_copy_roofline[{th}]")
        if k and c:
            out.append(f"- law kernel / copy kernel, {th} thread(s): {k[0] / c[0]:.2f}x")
    ref, k1 = rows.get("test_bench_numpy_reference"), rows.get("test_bench_numba[1]")
    if ref and k1:
        out.append(f"- numpy reference / numba (1 thread): {ref[0] / k1[0]:.1f}x")
    for name, (med, extra, _) in rows.items():
        if "speedup_vs" in extra and extra["speedup_vs"] in rows:
            out.append(f"- {extra['speedup_vs']} / {name}: {rows[extra['speedup_vs']][0] / med:.1f}x")
    dst.write_text("\n".join(out) + "\n")
    print(f"wrote {dst}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
