"""`opendyn sweep`: a scene run once per combination of the varied keys on a Dask cluster, one
Parquet row per run."""

from __future__ import annotations

import pathlib
import sys
import time

from .interrupts import _doing, _Interrupted
from .outputs import _check_not_inputs, _check_outputs, scene_stem
from .simulate import WRITE_FAILED, scene_for


def _sweep(args) -> int:
    """opendyn sweep: check the outputs, read every run's scene, run them on the cluster,
    report. Returns 0 when every run has a row (complete or failed)."""
    from ..errors import SweepInterrupted, SweepWriteError
    from ..sweep.engine import check_installed, sweep

    check_installed()
    vary = {}
    for item in args.vary:
        key, eq, spec = item.partition("=")
        if not eq or not key.strip():
            raise ValueError(f"--vary {item!r}: expected KEY=SPEC, e.g. control.kp=100:400:4")
        if key.strip() in vary:
            raise ValueError(f"--vary {key.strip()}: given twice")
        vary[key.strip()] = spec.strip()
    with _doing("loading the scene and its robot; nothing was run"):
        scene = scene_for(args.target, args.floating_base)
    output = args.output or f"{scene_stem(scene)}-sweep.parquet"
    named = [("-o", output, pathlib.Path(output))]
    if args.plot is not None:
        named.append(("--plot", args.plot, pathlib.Path(args.plot)))
    _check_outputs(named)
    _check_not_inputs(named, scene)
    if args.metric is not None and args.plot is None:
        raise ValueError(
            f"--metric {args.metric}: it picks the metric --plot draws; give --plot FILE.png "
            "(every metric is a column of the results table either way)"
        )
    if args.plot is not None:
        from ..sweep.plot import check_plan
        from ..sweep.specs import parse_axis

        check_plan([parse_axis(key, spec) for key, spec in vary.items()], args.metric)
    client = None
    if args.scheduler is not None:
        from ..sweep.cluster import connect

        client = connect(args.scheduler, "--scheduler")
    outputs = [m.strip() for m in args.outputs.split(",")] if args.outputs else None
    tic = time.perf_counter()
    try:
        table = sweep(
            scene, vary, samples=args.samples, seed=args.seed, client=client, outputs=outputs,
            parquet=output, trajectories=args.trajectories, workers=args.workers,
            chunk_size=args.chunk, progress=not args.quiet,
        )
    except SweepWriteError as e:
        # a full disk: which file, and that the rows so far are kept and the command resumes
        print(
            f"opendyn sweep: {e.filename}: {e.strerror}; {_counts(e.table)} so far are kept: "
            "the same command resumes from them once the file can be written",
            file=sys.stderr,
        )
        return WRITE_FAILED
    except SweepInterrupted as e:
        # one line, naming Ctrl-C or SIGTERM, and the exit status 130 or 143, as every command
        raise _Interrupted(
            f"sweeping; {_counts(e.table)} are saved in {output}: the same command resumes"
        ) from None
    finally:
        if client is not None:
            client.close()
    if args.plot is not None:
        from ..sweep.plot import plot_sweep

        with _doing("drawing the plot; the results are saved"):
            plot_sweep(table, args.plot, args.metric)
    if not args.quiet:
        print(f"{_counts(table)} in {time.perf_counter() - tic:.1f} s; wrote {output}"
              + (f", {args.plot}" if args.plot else ""))
        failed = [r for r in table.select(["run", "message"]).to_pylist()
                  if r["message"]]
        if failed:
            print(f"first failure, run {failed[0]['run']}: {failed[0]['message']}")
    return 0


def _counts(table) -> str:
    """'N runs (C complete, F failed)' of a sweep's results table."""
    from ..sweep.results import status_counts

    complete, failed = status_counts(table)
    return f"{table.num_rows} runs ({complete} complete, {failed} failed)"
