"""A look at a sweep's results: one metric against one or two varied keys.

    one numeric key:  metric(x), a line (a grid) or points (random samples)
    two numeric keys: metric(x, y), a heat map (a grid) or coloured points (random samples)

with one panel per value of the varied keys that are not numbers (run.integrator...). Failed
runs are drawn apart (red crosses on a line, grey cells of a heat map), since their metric
covers only the time before the failure.
"""

from __future__ import annotations

import numpy as np

from .results import read_record

# the metric drawn when none is named: the first of these that the table has
PREFERRED = (
    "tracking_rms",
    "setpoint_error",
    "violation_position_max",
    "penetration_max",
    "energy_error_max",
)


def plot_sweep(table, path, metric=None):
    """Draw `metric` (a column of the table; default: the first of PREFERRED it has) against
    the table's varied numeric keys, one panel per combination of its other varied keys, and
    save the figure to `path` (any format matplotlib writes). table: a sweep's results
    (opendyn.sweep). Raises ValueError naming the metric or the keys when it cannot be drawn.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    record = read_record(table)
    columns = table.to_pydict()
    metric = _metric(metric, record["outputs"])
    numeric, other = split_keys(
        {key: set(columns[key]) for key in record["vary"]},
        {key: table.schema.field(key).type == "double" for key in record["vary"]},
    )
    random = record["samples"] is not None
    panels = sorted({tuple(columns[k][i] for k in other) for i in range(table.num_rows)}, key=str)
    fig, axes = plt.subplots(
        1, len(panels), figsize=(0.6 + 4.6 * len(panels), 4.0), squeeze=False,
        constrained_layout=True,
    )
    ok = np.array([status == "complete" for status in columns["status"]])
    z = _values(columns, metric, range(table.num_rows))
    norm = _norm(z[ok & np.isfinite(z)])
    for ax, panel in zip(axes[0], panels):
        rows = [i for i in range(table.num_rows)
                if tuple(columns[k][i] for k in other) == panel]
        if len(numeric) == 1:
            _line(ax, columns, rows, numeric[0], metric, random, record["log"], norm)
        else:
            image = _heat_map(ax, columns, rows, numeric, metric, random, record["log"], norm)
        ax.set_title(", ".join(f"{k} = {v}" for k, v in zip(other, panel)), fontsize=9)
    if len(numeric) == 2:
        fig.colorbar(image, ax=list(axes[0]), label=metric)
    failed = int((~ok).sum())
    fig.suptitle(
        f"{record.get('name') or record['source']}: {metric}, {table.num_rows} runs"
        + (f" ({failed} failed: {'red crosses' if len(numeric) == 1 or random else 'grey'})"
           if failed else ""),
        fontsize=10,
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)


def check_plan(axes, metric):
    """Before a sweep runs: ValueError if its table could not be drawn (`axes`: its
    opendyn.sweep.Axis list; `metric`: a name, or None), as plot_sweep would find."""
    from ..sim.metrics import METRICS

    many = {"drawn", "values"}  # a distribution's values, all different
    split_keys(
        {a.key: set(a.values) if a.values else many for a in axes},
        {a.key: bool(a.distribution) or all(type(v) is float for v in a.values) for a in axes},
    )
    if metric is not None:
        _metric(metric, METRICS)


def split_keys(values, is_number):
    """(numeric, other): the varied keys that take more than one value, numbers apart from the
    rest ({key: set of its values}, {key: whether its values are numbers}); ValueError unless
    one or two are numbers."""
    varied = [key for key, v in values.items() if len(v) > 1]
    numeric = [key for key in varied if is_number[key]]
    if not numeric or len(numeric) > 2:
        raise ValueError(
            f"--plot draws a metric against one or two varied numbers; this sweep varies "
            f"{len(numeric)} ({', '.join(numeric) or 'none'})"
        )
    return numeric, [key for key in varied if not is_number[key]]


def _metric(metric, outputs):
    """The metric to draw: `metric`, or the first of PREFERRED among `outputs`."""
    drawable = list(outputs) + ["wall_s", "steps", "evaluations"]
    if metric is None:
        metric = next((m for m in PREFERRED if m in outputs), None)
    if metric not in drawable:
        raise ValueError(
            f"--metric: {metric!r} is not a metric of this sweep; its metrics: "
            f"{', '.join(drawable)}"
        )
    return metric


def _values(columns, key, rows):
    return np.array([np.nan if columns[key][i] is None else columns[key][i] for i in rows], float)


def _norm(good):
    """A colour scale over the complete runs' values: logarithmic when they are positive and
    span more than two decades."""
    from matplotlib.colors import LogNorm, Normalize

    if not len(good):
        return Normalize(0.0, 1.0)
    if good.min() > 0 and good.max() > 100 * good.min():
        return LogNorm(good.min(), good.max())
    return Normalize(good.min(), good.max())


def _line(ax, columns, rows, key, metric, random, log, norm):
    x, z = _values(columns, key, rows), _values(columns, metric, rows)
    ok = np.array([columns["status"][i] == "complete" for i in rows])
    order = np.argsort(x, kind="stable")
    x, z, ok = x[order], z[order], ok[order]
    ax.plot(x[ok], z[ok], "." if random else "o-", ms=4)
    if not ok.all():  # along the bottom: their metric covers only the time before the failure
        ax.plot(x[~ok], np.full((~ok).sum(), norm.vmin), "x", color="red", label="failed")
        ax.legend(fontsize=8)
    ax.set_xlabel(key)
    ax.set_ylabel(metric)
    if key in log:
        ax.set_xscale("log")
    if norm.__class__.__name__ == "LogNorm":
        ax.set_yscale("log")


def _heat_map(ax, columns, rows, keys, metric, random, log, norm):
    """metric(x, y) as cells around the grid points (coloured points for random samples);
    failed runs as grey cells (red crosses). Returns the coloured artist."""
    x, y = (_values(columns, k, rows) for k in keys)
    z = _values(columns, metric, rows)
    ok = np.array([columns["status"][i] == "complete" for i in rows])
    xs, ys = np.unique(x), np.unique(y)
    if random or len(xs) * len(ys) != len(rows):
        image = ax.scatter(x[ok], y[ok], c=z[ok], norm=norm, s=14)
        ax.plot(x[~ok], y[~ok], "x", color="red")
    else:
        grid = np.full((len(ys), len(xs)), np.nan)
        failed = np.full_like(grid, np.nan)
        for xi, yi, zi, oki in zip(x, y, z, ok):
            cell = (np.searchsorted(ys, yi), np.searchsorted(xs, xi))
            if oki:
                grid[cell] = zi
            else:
                failed[cell] = 1.0
        edges = (_edges(xs, keys[0] in log), _edges(ys, keys[1] in log))
        image = ax.pcolormesh(*edges, grid, norm=norm, shading="flat")
        ax.pcolormesh(*edges, failed, cmap="Greys", vmin=0.0, vmax=2.5, shading="flat")
    for key, axis in zip(keys, ("x", "y")):
        getattr(ax, f"set_{axis}label")(key)
        if key in log:
            getattr(ax, f"set_{axis}scale")("log")
    return image


def _edges(centres, log):
    """Cell edges around grid points: the midpoints (in log space for a log grid), the ends
    mirrored; a single point gets a cell of its own size."""
    c = np.log(centres) if log else np.asarray(centres, float)
    if len(c) == 1:
        half = 0.1 if log else max(abs(c[0]) * 0.1, 0.5)
        e = np.array([c[0] - half, c[0] + half])
    else:
        mid = (c[1:] + c[:-1]) / 2
        e = np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])
    return np.exp(e) if log else e
