"""viz plots: figures hold the expected artists and are written as real PNG images."""

import numpy as np
import pytest
from matplotlib.image import AxesImage
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Rectangle
from PIL import Image

from kinserve import robots, viz
from kinserve.kinematics import InputError, ShapeError


def check_png(path, min_colors=3):
    """A decodable PNG of plausible size that is not a blank canvas."""
    assert path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape[0] > 200 and img.shape[1] > 200
    assert len(np.unique(img.reshape(-1, 3), axis=0)) >= min_colors
    return img


def test_joints_figure_one_line_per_joint_plus_limits(tmp_path):
    t = np.linspace(0, 2, 50)
    Q = np.c_[np.sin(t), np.cos(t), t, t ** 2]
    fig = viz.joints_figure(t, Q, ["a", "b", "c", "d"], limits=([-1] * 4, [1] * 4), xlabel="time (s)")
    ax = fig.axes[0]
    assert len(ax.lines) == 4 + 8  # joints + a dotted lower/upper line each
    np.testing.assert_allclose(ax.lines[2].get_ydata(), t)
    assert [text.get_text() for text in ax.get_legend().get_texts()] == ["a", "b", "c", "d"]
    assert ax.get_xlabel() == "time (s)"
    check_png(viz.save_png(fig, tmp_path / "plots" / "joints.png"))


def test_errors_figure_log_scale_floors_zeros(tmp_path):
    e = {"position": np.array([1.0, 0.1, 1e-3, 0.0]), "orientation": np.array([0.5, 0.05, 0.0, 0.0])}
    fig = viz.errors_figure(None, e, tolerance=1e-6)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    assert len(ax.lines) == 3  # two series + the tolerance line
    np.testing.assert_allclose(ax.lines[0].get_xdata(), np.arange(4))
    assert ax.lines[0].get_ydata()[-1] == viz.plots.LOG_FLOOR
    check_png(viz.save_png(fig, tmp_path / "errors.png"))


def test_joints_and_errors_two_panels(tmp_path):
    it = np.arange(30)
    Q = np.random.default_rng(0).normal(size=(30, 4)).cumsum(axis=0)
    E = np.exp(-0.3 * it)[:, None] * np.array([1.0, 2.0, 3.0])
    fig = viz.joints_and_errors_figure(it, Q, E)
    top, bottom = fig.axes
    assert len(top.lines) == 4 and len(bottom.lines) == 3
    check_png(viz.save_png(fig, tmp_path / "s9.png"))


def test_manipulability_threshold_shading(tmp_path):
    t = np.linspace(0, 1, 101)
    w = np.abs(np.cos(np.pi * t))
    fig = viz.manipulability_figure(t, w, threshold=0.1)
    ax = fig.axes[0]
    assert len(ax.lines) == 2 and len(ax.collections) == 1  # w, threshold; the shaded band
    check_png(viz.save_png(fig, tmp_path / "w.png"))


def test_series_and_xy_figures(tmp_path):
    fig = viz.series_figure(np.arange(5), {"a": np.arange(5.0), "b": np.ones(5)}, ylabel="value")
    assert len(fig.axes[0].lines) == 2
    th = np.linspace(0, 2 * np.pi, 100)
    ref = np.c_[1 + 0.2 * np.cos(th), 0.25 + 0.2 * np.sin(th)]
    fig = viz.xy_figure({"reference": ref, "followed": ref + 0.01}, points={"start": ref[0]})
    assert len(fig.axes[0].lines) == 3
    check_png(viz.save_png(fig, tmp_path / "xy.png"))


def test_map_figure_artists(tmp_path):
    obstacles = [viz.Rect(220, 100, 260, 140, "hot-dog 1"), {"rect": [160, 160, 200, 200]},
                 {"circle": [240, 240, 40]}]
    mask = np.zeros((48, 48), bool)
    mask[:10, :20] = True
    fig = viz.map_figure(obstacles, (0, 0, 480, 480),
                         paths={"leg 1": [[260, 60], [360, 170]], "leg 2": [[360, 170], [150, 70]]},
                         waypoints={"start": (260, 60), "1": (360, 170)},
                         coverage=viz.Grid(mask, cell=10.0), inflate=10)
    ax = fig.axes[0]
    rects = [p for p in ax.patches if isinstance(p, Rectangle)]
    circles = [p for p in ax.patches if isinstance(p, CirclePatch)]
    assert len(rects) == 4 and len(circles) == 2  # obstacles + their inflated outlines
    assert len(ax.lines) == 2 + 2  # paths + waypoint markers
    images = [a for a in ax.get_children() if isinstance(a, AxesImage)]
    assert len(images) == 1 and images[0].get_extent() == [0, 480, 0, 480]
    assert ax.get_xlim() == (0, 480)
    img = check_png(viz.save_png(fig, tmp_path / "map.png"))
    # obstacle brown (#8c564b) is actually painted
    assert (np.abs(img.astype(int) - [0x8C, 0x56, 0x4B]).sum(axis=2) < 30).sum() > 500


def test_planar_chain_matches_the_robot_model(rng):
    arm = robots.load("planar4r")
    lengths = [1.0, 0.8, 0.6, 0.4]
    for _ in range(5):
        q = arm.random_q(rng)
        P = viz.planar_chain(lengths, q)
        assert P.shape == (5, 2)
        np.testing.assert_allclose(P[-1], arm.fk(q)[:2, 3], atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(np.diff(P, axis=0), axis=1), lengths)


def test_planar_arm_family_figure(tmp_path):
    lengths = [1.0, 0.8, 0.6, 0.4]
    up = np.random.default_rng(1).uniform(-1, 1, size=(40, 4))
    down = np.random.default_rng(2).uniform(-1, 1, size=(7, 4))
    fig = viz.planar_arm_figure(lengths, {"elbow up": up, "elbow down": down}, target=(1.2, 0.8, 0.3),
                                max_per_branch=10)
    ax = fig.axes[0]
    arms = [ln for ln in ax.lines if len(ln.get_xdata()) == 5]
    assert len(arms) == 10 + 7
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["elbow up (40)", "elbow down (7)", "target"]
    check_png(viz.save_png(fig, tmp_path / "family.png"))


def test_bad_plot_input():
    with pytest.raises(ShapeError):
        viz.joints_figure(np.arange(3), np.zeros((4, 2)))
    with pytest.raises(ShapeError):
        viz.joints_figure(None, np.zeros((4, 2)), names=["only one"])
    with pytest.raises(ShapeError):
        viz.errors_figure(None, {"a": np.zeros(3), "b": np.zeros(4)})
    with pytest.raises(InputError, match="png"):
        viz.save_png(viz.series_figure(None, np.zeros(3)), "plot.jpg")
    with pytest.raises(InputError):
        viz.planar_arm_figure([1, 1], {})


def test_layout_checks_catch_a_cut_title_and_a_legend_on_the_curves():
    """The checks the scenario plot tests use (figure_checks) fail on the faults they look for."""
    from figure_checks import axis_labels, legends_clear_of_data, titles_inside

    t = np.linspace(0, 15, 501)
    e = np.where(t > 14.5, 1e-6, 1e-16)  # a spike at the right end, under an upper-right legend
    fig = viz.errors_figure(t, {"position": e, "orientation": 0.5 * e}, xlabel="time (s)",
                            title="S4 tracking errors of DLS IK (λ = 0.05, warm started, "
                                  "null-space centring, 501 samples)")
    fig.axes[0].legend(loc="upper right")
    with pytest.raises(AssertionError, match="outside the figure"):
        titles_inside(fig)
    with pytest.raises(AssertionError, match="covers"):
        legends_clear_of_data(fig)
    fig.axes[0].set_xlabel("")
    with pytest.raises(AssertionError, match="no x label"):
        axis_labels(fig.axes[0])
    # the same data with a short title and the legend below the axes passes
    fig = viz.errors_figure(t, {"position": e, "orientation": 0.5 * e}, xlabel="time (s)",
                            title="S4 tracking errors")
    fig.axes[0].get_legend().remove()
    fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=2)
    titles_inside(fig)
    legends_clear_of_data(fig)
    axis_labels(fig.axes[0])


@pytest.mark.parametrize("kwargs, message", [
    ({"count_in_label": "no"}, "count_in_label must be True or False"),
    ({"max_per_branch": 2.5}, "max_per_branch must be an integer"),
    ({"max_per_branch": -1}, "max_per_branch must be an integer from 1"),
    ({"target": "no"}, "target must"), ({"target": (1.0, 0.0, float("nan"))}, "target must"),
    ({"base": (0.0, 0.0, 0.0)}, r"base must have shape \(2"), ({"link_lengths": "ab"}, "link_lengths must"),
    ({"branches": {"up": [[float("nan")] * 2]}}, r"branches\['up'\] must"),
])
def test_planar_arm_figure_refuses_what_it_would_misdraw(kwargs, message):
    """``count_in_label="no"`` put the count in the label, ``max_per_branch=2.5`` drew 2, a NaN angle drew
    nothing, and a bad target, base or link length raised NumPy's errors; each now names the argument."""
    args = {"link_lengths": [1.0, 1.0], "branches": {"up": [[0.1, 0.2], [0.3, 0.4]]}}
    args.update(kwargs)
    with pytest.raises((InputError, ShapeError), match=message):
        viz.planar_arm_figure(args.pop("link_lengths"), args.pop("branches"), **args)
    with pytest.raises((InputError, ShapeError), match="q"):
        viz.planar_chain([1.0, 1.0], [float("nan"), 0.0])


def _fig():
    return viz.series_figure(None, {"a": np.arange(3.0)})


@pytest.mark.parametrize("call, message", [
    (lambda p: viz.save_png(_fig(), p / "o.png", dpi=0), "dpi must be an integer from 10 to 1,200"),
    (lambda p: viz.save_png(_fig(), p / "o.png", dpi=10**6), "dpi must be an integer from 10 to 1,200"),
    (lambda p: viz.save_png(_fig(), p / "o.png", dpi=2.5), "dpi must be an integer"),
    (lambda p: viz.save_png(_fig(), p / "o.png", dpi=float("nan")), "dpi must be an integer"),
    (lambda p: viz.save_png(_fig(), 3), "path must be a file path"),
    (lambda p: viz.map_figure([], (0, 0, float("nan"), 1)), "bounds"),
    (lambda p: viz.map_figure([], (0, 0, -1, 1)), "xmin < xmax"),
    (lambda p: viz.map_figure(2.5), "obstacles must be a list"),
    (lambda p: viz.map_figure([], paths=2.5), "paths must be"),
    (lambda p: viz.map_figure([], waypoints=2.5), "waypoints must be"),
    (lambda p: viz.map_figure([], waypoints=[(1.0, float("nan"))]), r"waypoints\[0\]"),
    (lambda p: viz.map_figure([], inflate=float("nan")), "inflate must be finite"),
    (lambda p: viz.map_figure([], inflate="no"), "inflate must be a number"),
    (lambda p: viz.map_figure([], inflate=1e300), "inflate must be finite"),
    (lambda p: viz.Circle(float("nan"), 0.0, 1.0), "Circle cx must be finite"),
    (lambda p: viz.Circle(0.0, 0.0, float("inf")), "Circle radius must be finite"),
    (lambda p: viz.Rect(0.0, 0.0, float("inf"), 1.0), "Rect xmax must be finite"),
    (lambda p: viz.Rect("no", 0.0, 1.0, 1.0), "Rect xmin must be a number"),
    (lambda p: viz.Rect(0.0, 0.0, 1.0, 1.0, name=3), "Rect name must be a str"),
    (lambda p: viz.Grid(np.zeros(4)), "grid mask must be a 2-D boolean grid"),
    (lambda p: viz.Grid(np.zeros((2, 2)), cell=0.0), "Grid cell must be positive"),
    (lambda p: viz.errors_figure(None, {"a": np.ones(3)}, tolerance=np.nan), "tolerance must be finite"),
    (lambda p: viz.errors_figure(None, {"a": np.ones(3)}, tolerance="no"), "tolerance must be a number"),
    (lambda p: viz.errors_figure(None, {"a": [1.0, np.inf]}), r"error\['a'\] must hold finite numbers"),
    (lambda p: viz.manipulability_figure(None, np.ones(3), threshold="no"), "threshold must be a number"),
    (lambda p: viz.manipulability_figure(None, np.ones(3), threshold=np.nan), "threshold must be finite"),
    (lambda p: viz.joints_figure(None, np.zeros((3, 2)), limits=0), "limits must be"),
    (lambda p: viz.joints_figure(None, np.zeros((3, 2)), names=0), "names must be a sequence of 2"),
    (lambda p: viz.joints_figure(None, np.zeros((3, 2)), limits=([0, 0], [1, "x"])), "limits upper"),
    (lambda p: viz.xy_figure({"c": np.zeros((3, 2))}, points=2.5), "points must be a dict"),
    (lambda p: viz.series_figure(["a", "b"], np.zeros(2)), "x must be a number or an array"),
])
def test_plots_and_map_shapes_name_a_bad_argument(tmp_path, call, message):
    """Found by feeding bad values to every plotting argument: a NaN bound raised matplotlib's "Axis limits
    cannot be NaN or Inf", dpi=10**6 ran out of memory, ``Rect("no", ...)`` a TypeError, a NaN tolerance or
    radius was drawn as nothing; each is now refused by name (InputError or one of its subclasses)."""
    with pytest.raises(InputError, match=message):
        call(tmp_path)


def test_plots_still_take_their_ordinary_arguments(tmp_path):
    fig = viz.map_figure([viz.Rect(0, 0, 1, 1), {"circle": [3, 3, 1]}], (-1, -1, 5, 5),
                         paths=[np.zeros((2, 2))], waypoints={"a": (1, 2)},
                         coverage=np.zeros((2, 2), dtype=bool), inflate=0.5)
    assert viz.save_png(fig, tmp_path / "m.png", dpi=50.0).stat().st_size > 0
    fig = viz.errors_figure(None, {"a": np.ones(3), "b": [1.0, np.nan, np.nan]}, tolerance=1e-3)  # NaN: gaps
    assert np.isnan(fig.axes[0].lines[1].get_ydata()).sum() == 2
    viz.manipulability_figure(None, np.ones(3), threshold=0.0)
    viz.joints_figure(None, np.zeros((3, 2)), names=("a", "b"), limits=([-1, -1], [1, 1]))
    viz.xy_figure({"c": np.zeros((3, 2))}, points={"p": (0.0, 1.0)})
    assert viz.Grid([[True, False]], origin=(1, 2), cell=2).extent == (1.0, 5.0, 2.0, 4.0)


_E = {"e": np.ones(3)}


@pytest.mark.parametrize("call, message", [
    (lambda: viz.series_figure(None, _E, xlabel=3), "xlabel must be a str, got 3"),
    (lambda: viz.series_figure(None, _E, ylabel=np.zeros(0)), "ylabel must be a str"),
    (lambda: viz.series_figure(None, _E, title=None), "title must be a str, got None"),
    (lambda: viz.joints_figure(None, np.zeros((3, 2)), ylabel=float("nan")), "ylabel must be a str"),
    (lambda: viz.errors_figure(None, _E, title=True), "title must be a str, got True"),
    (lambda: viz.joints_and_errors_figure(None, np.zeros((3, 2)), _E, title=np.zeros(0)),
     "title must be a str"),
    (lambda: viz.manipulability_figure(None, np.ones(3), xlabel=object()), "xlabel must be a str"),
    (lambda: viz.xy_figure({"c": np.zeros((3, 2))}, ylabel=1e300), "ylabel must be a str"),
    (lambda: viz.map_figure([], units=0), "units must be a str, got 0"),
    (lambda: viz.map_figure([], title=["t"]), "title must be a str"),
])
def test_plot_labels_must_be_text(call, message):
    """Axis labels, titles and units were drawn whatever they were (``title=True`` read "True", ``units=0``
    "x (0)") and an empty array raised NumPy's ambiguous-truth error; each is now refused by name."""
    with pytest.raises(InputError, match=message):
        call()
    assert viz.series_figure(None, _E, xlabel="", ylabel="y", title="t").axes[0].get_title() == "t"
