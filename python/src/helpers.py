"""Python-side helpers of the ezy extension module (drawing with matplotlib).

Compiled into every module built with ezy_python (the `ezy` package and a
user's own, `ezy_python::python_module!`), so both draw alike.
"""


def draw(chart, ax=None):
    """Draw one chart given by ezy as a dict (see ezy's `figures::chart`).

    `chart` holds the title, axis labels, the series (label, x and y arrays,
    panel 0 or 1, stroke, colour index), whether a lower panel, equal axes,
    a logarithmic y axis and shaded stretches of x are asked for. `ax` is an
    Axes to draw into (single-panel charts only); without it a new Figure
    is made. Returns the matplotlib Figure.
    """
    import matplotlib.pyplot as plt

    two = chart["lower"] is not None
    if ax is not None:
        if two:
            raise ValueError(
                f"figure `{chart['file']}` has two panels: leave out ax= to get a new Figure"
            )
        fig, axes = ax.figure, [ax]
    elif two:
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 6), constrained_layout=True)
    else:
        fig, axes = plt.subplots(1, 1, figsize=(8, 5.3), constrained_layout=True)
        axes = [axes]
    dashes = ["--", ":", (0, (8, 2))]
    for k, s in enumerate(chart["series"]):
        a = axes[min(s["panel"], len(axes) - 1)]
        colour = f"C{(s['color'] if s['color'] is not None else k) % 10}"
        stroke = s["stroke"]
        if stroke == "points":
            a.plot(s["x"], s["y"], "D", color=colour, label=s["label"] or None, markersize=4)
            continue
        style = "-" if stroke in ("auto", "solid", "pieces") else dashes[int(stroke[4:]) % 3]
        a.plot(s["x"], s["y"], linestyle=style, color=colour, label=s["label"] or None)
        if chart["equal_axes"] and chart["path_ends"] and stroke != "pieces" and len(s["x"]) > 0:
            a.plot(s["x"][:1], s["y"][:1], "o", color=colour)
            a.plot(s["x"][-1:], s["y"][-1:], "s", color=colour)
    for a in axes:
        for x0, x1 in chart["shade"]:
            a.axvspan(x0, x1, color="0.9", zorder=0)
        if chart["log_y"]:
            a.set_yscale("log")
            a.set_ylim(bottom=chart["log_floor"])
        if chart["log_x"]:
            a.set_xscale("log")
        if chart["equal_axes"]:
            a.set_aspect("equal", adjustable="datalim")
        a.grid(True, alpha=0.3)
        if any(line.get_label() and not line.get_label().startswith("_") for line in a.get_lines()):
            a.legend(loc="best")
    axes[0].set_title(chart["title"])
    axes[0].set_ylabel(chart["y_label"])
    if two:
        axes[1].set_ylabel(chart["lower"])
    axes[-1].set_xlabel(chart["x_label"])
    return fig


def to_pandas(data, columns, units=None):
    """A pandas DataFrame over the run's 2-D array (rows x columns); each
    column's unit in `frame.attrs["units"]`."""
    import pandas as pd

    frame = pd.DataFrame(data, columns=list(columns), copy=False)
    if units is not None:
        frame.attrs["units"] = dict(units)
    return frame


def read_table(path, index=None):
    """The CSV table `path` written by a command, as a DataFrame (`index`:
    the column to index it by)."""
    import pandas as pd

    return pd.read_csv(path, comment="#", index_col=index)


def frame(columns, parameters):
    """A run with its sensitivities as a DataFrame (`columns`: name to
    values), the parameters differentiated in `.attrs["parameters"]`: what
    an objective of the caller's own is given."""
    import pandas as pd

    f = pd.DataFrame(columns)
    f.attrs["parameters"] = list(parameters)
    return f


def sweep_frame(path):
    """The sweep table `path` (sweep.csv) as a DataFrame, run index first."""
    import pandas as pd

    return pd.read_csv(path, comment="#")


def eigenvalues(path):
    """The eigenvalues.csv `path` (k, re, im) as a complex NumPy array."""
    import numpy as np

    frame = read_table(path)
    return np.asarray(frame["re"], dtype=float) + 1j * np.asarray(frame["im"], dtype=float)


def state(path):
    """The state.csv `path` (name, value) as a dict."""
    frame = read_table(path)
    return {str(n): float(v) for n, v in zip(frame["name"], frame["value"])}
