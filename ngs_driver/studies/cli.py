"""``dam-seismic ida``: incremental dynamic analysis over a FEMA P695 suite on Dask.

    dam-seismic ida SCENE --suite fema-p695-farfield [--records 1,2] [--components a,b]
        --im pga|sa --levels 0.05,0.1 --out DIR [--workers N | --scheduler tcp://HOST:PORT]
        [--set KEY=VALUE ...] [--window scene|record] [--failed exceed|exclude]
        [--no-plots] [--quiet]

Exit codes: 0 done (physical solver failures are results), 1 some runs ended in an error
(re-run the command: finished runs are skipped), 2 bad input (nothing submitted).
"""
from __future__ import annotations

import argparse
import sys

from ..setup import fema_records as fema


def add_ida_parser(sub):
    p = sub.add_parser("ida", help="incremental dynamic analysis over a FEMA P695 record suite "
                                   "on Dask -> ida.csv, fragility.json, PNGs",
                       description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="shipped scene name (e.g. koyna) or path to a .toml file")
    p.add_argument("--set", action="append", default=[], dest="overrides", metavar="KEY=VALUE",
                   help="override a scene key (repeatable), e.g. --set time.duration=0.1")
    p.add_argument("--suite", required=True, help=f"record suite: {', '.join(fema.SUITES)}")
    p.add_argument("--records", default=None,
                   help="record numbers, e.g. 1,2,7 (default: all of the suite)")
    p.add_argument("--components", default=None, help="a, b or a,b (default a,b)")
    p.add_argument("--im", required=True, help="intensity measure: pga or sa (Sa(T1, 5 %%))")
    p.add_argument("--levels", required=True, help="IM levels in g, e.g. 0.05,0.1,0.2")
    p.add_argument("--out", required=True, help="study directory")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, default=None,
                   help="local cluster with N single-threaded workers (default: one per core)")
    g.add_argument("--scheduler", default=None,
                   help="address of a running Dask scheduler, e.g. tcp://127.0.0.1:8786")
    p.add_argument("--failed", default="exceed", choices=("exceed", "exclude"),
                   help="runs that fail physically count as exceeding every limit state "
                        "(default) or are left out of the fragility fits")
    p.add_argument("--window", default="scene", choices=("scene", "record"),
                   help="analysed window: the scene's ground_motion.start/time.duration "
                        "(default) or each record whole (start 0, duration = its length)")
    p.add_argument("--limit-state", action="append", default=[], dest="limit_states",
                   metavar="NAME=COLUMN:THRESHOLD",
                   help="a limit state of fragility.json besides the defaults (the same NAME "
                        "replaces a default), e.g. slip_1m=slip_residual_m:1.0 (repeatable)")
    p.add_argument("--no-plots", action="store_true", help="no PNGs")
    p.add_argument("--quiet", action="store_true", help="no progress bar, log file only")
    return p


def _err(msg, code=2):
    print(f"dam-seismic ida: error: {msg}", file=sys.stderr)
    return code


def cmd_ida(a) -> int:
    # deferred: the study's modules (Dask, scipy.stats) load only for this command, not for
    # every command that builds the parser (0.3-0.6 s of each `dam-seismic run`, measured)
    from .fragility import parse_limit_state
    from .ida import StudyInputError, parse_list, run_ida
    try:
        records = parse_list(a.records, "--records", int)
        comps = parse_list(a.components, "--components", str)
        levels = parse_list(a.levels, "--levels", float)
        limit_states = [parse_limit_state(x) for x in a.limit_states]
        res = run_ida(a.scene, overrides=a.overrides, suite=a.suite, records=records,
                      components=comps, im=a.im, levels=levels, out=a.out,
                      workers=a.workers, scheduler=a.scheduler, failed=a.failed,
                      plots=not a.no_plots, progress=not a.quiet, window=a.window,
                      limit_states=limit_states)
    except fema.MissingRecordsPackage as e:
        return _err(str(e))
    except (StudyInputError, ValueError) as e:
        return _err(str(e))
    except KeyboardInterrupt:
        print(f"\ninterrupted; the same command continues (finished runs in {a.out} are "
              "skipped)", file=sys.stderr)
        return 3
    if res["errors"]:
        return _err(f"{len(res['errors'])} run(s) ended in an error (see {a.out}/ida.log); the "
                    "same command retries them", 1)
    return 0
