"""Top-down map of a scene spec (PNG): walls, furniture, Zones 1/2/3, face arrows, goals with their
success radii, and the robot's navigable area. Episodes can be overlaid (start, goal, path), and a busy
episode's people: where they stand at its start and the paths they walk.

Figures are laid out once (matplotlib's constrained layout where there are panels, then frozen), text
labels are placed where they overlap no other label (:func:`place_labels`), and the figure is then fitted
to its content (:func:`fit_figure`): a legend outside the axes, an axis label or a title is never cut off.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, FancyArrow, Polygon as MplPolygon  # noqa: E402
from matplotlib.layout_engine import PlaceHolderLayoutEngine  # noqa: E402
from matplotlib.text import Text  # noqa: E402
from matplotlib.transforms import Bbox  # noqa: E402

from biovln_ms.catalog import load_catalog  # noqa: E402
from biovln_ms.people.body import PERSON_RADIUS  # noqa: E402
from biovln_ms.scene.rules import scene_free_space  # noqa: E402
from biovln_ms.scene.spec import SceneSpec  # noqa: E402

DRESSING_COLOR = "#c8b89a"  # lab dressing: bodies in the way, no zones
PERSON_COLOR = "#ff7f0e"  # people: bodies and the paths they walk
UNKNOWN_COLOR = "#999999"  # a category the catalog lacks
LABEL_GID = "label"  # the gid of every label place_labels adds
LABEL_RINGS = (4.0, 9.0, 15.0, 23.0, 33.0, 46.0, 62.0)  # points from the anchor, nearest first
LABEL_ANGLES = (45, 0, 90, -45, 135, 180, -90, -135, 22, 68, 158, -22, -68, -158, 112, -112)  # degrees
LABEL_PAD = 1.5  # points of clearance kept around each label's text
ANCHOR_CLEARANCE = 5.0  # points: no label covers this square around an anchor (its marker)
MAP_MARGIN = 0.4  # m of floor shown around the rooms
MAP_WIDTH, MAP_MAX_HEIGHT = 9.0, 8.0  # inches of a map's axes (a deep scene: its height)


def category_color(category: str) -> str:
    """A category's colour on the map: its catalog entry's (``AssetSpec.color``), so a new instrument
    brings its own."""
    catalog = load_catalog()
    return catalog.get(category).color if category in catalog else UNKNOWN_COLOR


def _poly(ax, coords, **kw):
    ax.add_patch(MplPolygon(np.asarray(coords), closed=True, **kw))


def _draw_geom(ax, geom, **kw):
    for g in getattr(geom, "geoms", [geom]):
        if g.is_empty:
            continue
        _poly(ax, np.asarray(g.exterior.coords), **kw)
        for hole in g.interiors:
            _poly(ax, np.asarray(hole.coords), facecolor="white", edgecolor="none")


def _overlaps(boxes: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Area each of ``boxes`` (K, 4: x0, y0, x1, y1) shares with each of ``others`` (N, 4): (K, N)."""
    lo = np.maximum(boxes[:, None, :2], others[None, :, :2])
    hi = np.minimum(boxes[:, None, 2:], others[None, :, 2:])
    return np.clip(hi - lo, 0.0, None).prod(axis=2)


def _spots() -> tuple[np.ndarray, list[tuple[str, str]], np.ndarray]:
    """The candidate spots, nearest first: (K, 2) offsets in points, the text alignment that puts the label
    on the side of its anchor the offset points to, and each spot's ring."""
    offsets, aligns, rings = [], [], []
    for ring in LABEL_RINGS:
        for angle in LABEL_ANGLES:
            c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
            offsets.append((ring * c, ring * s))
            aligns.append(
                ("left" if c > 0.3 else "right" if c < -0.3 else "center",
                 "bottom" if s > 0.3 else "top" if s < -0.3 else "center")
            )  # fmt: skip
            rings.append(ring)
    return np.asarray(offsets), aligns, np.asarray(rings)


def freeze_layout(fig) -> None:
    """Apply the figure's layout engine once and switch it off, with each axes' aspect applied: the axes stay
    where they are from here, so what is placed in pixels (labels) stays placed. Add every panel, title and
    legend first."""
    engine = fig.get_layout_engine()
    if engine is not None and not isinstance(engine, PlaceHolderLayoutEngine):
        engine.execute(fig)
        fig.set_layout_engine("none")
    for ax in fig.axes:
        ax.apply_aspect()


def fit_figure(fig, pad: float = 0.08) -> None:
    """Freeze the layout, then resize the figure to its content (axes, their decorations, labels and
    legends) plus ``pad`` inches, each axes keeping its size in inches: nothing sticks out of the figure, no
    margin is left empty, and labels placed in pixels keep their places. Legends belong to axes
    (``ax.legend``); a figure-level legend would not move with them."""
    freeze_layout(fig)
    renderer = fig.canvas.get_renderer()
    boxes = []
    for ax in fig.axes:
        extra = [*ax.texts, *([ax.get_legend()] if ax.get_legend() is not None else [])]
        boxes.append(ax.get_tightbbox(renderer, bbox_extra_artists=extra))
    box = Bbox.union([b for b in boxes if b is not None])
    dpi = fig.dpi
    x0, y0 = box.x0 / dpi - pad, box.y0 / dpi - pad
    w, h = box.width / dpi + 2 * pad, box.height / dpi + 2 * pad
    width, height = fig.get_size_inches()
    for ax in fig.axes:
        p = ax.get_position()
        ax.set_position(
            [(p.x0 * width - x0) / w, (p.y0 * height - y0) / h, p.width * width / w, p.height * height / h]
        )
    fig.set_size_inches(w, h)


def place_labels(ax, anchors, texts, fontsize: float = 7, avoid=(), **text_kw) -> list:
    """Label each anchor (data x, y) with its text at the nearest spot, on rings around it, where the label
    overlaps no other label, covers no anchor nor point of ``avoid`` (data x, y: other markers) and stays
    inside the axes; a label off its anchor's side is tied to it by a thin line. Where no spot is free, the
    one overlapping least. Labels are placed in pixels, so the layout is frozen first
    (:func:`freeze_layout`). Returns the annotations (gid ``LABEL_GID``)."""
    anchors = [tuple(map(float, a)) for a in anchors]
    if not anchors:
        return []
    fig = ax.figure
    freeze_layout(fig)
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    frame = np.asarray(ax.get_window_extent(renderer).extents)
    points = ax.transData.transform(np.asarray(anchors))
    r = ANCHOR_CLEARANCE * px
    taken = [np.array([x - r, y - r, x + r, y + r]) for x, y in points]
    marks = ax.transData.transform(np.asarray(avoid, float).reshape(-1, 2))
    taken += [np.array([x - r, y - r, x + r, y + r]) for x, y in marks]
    offsets, aligns, rings = _spots()
    shift_x = {"left": 0.0, "center": 0.5, "right": 1.0}
    shift_y = {"bottom": 0.0, "center": 0.5, "top": 1.0}
    out = []
    for i, ((x, y), anchor, text) in enumerate(zip(points, anchors, texts)):
        ext = Text(0, 0, text, fontsize=fontsize, figure=fig).get_window_extent(renderer)
        pad = LABEL_PAD * px
        w, h = ext.width + 2 * pad, ext.height + 2 * pad
        x0 = x + offsets[:, 0] * px - np.array([shift_x[a] for a, _ in aligns]) * (w - 2 * pad) - pad
        y0 = y + offsets[:, 1] * px - np.array([shift_y[b] for _, b in aligns]) * (h - 2 * pad) - pad
        boxes = np.stack([x0, y0, x0 + w, y0 + h], axis=1)
        others = np.asarray(taken[:i] + taken[i + 1 :]).reshape(-1, 4)  # all but its own anchor
        outside = w * h - _overlaps(boxes, frame[None])[:, 0]
        cost = _overlaps(boxes, others).sum(axis=1) + 4 * outside
        free = np.flatnonzero(cost < 1e-6)  # px²: rounding leaves a box inside the frame a speck outside
        k = int(free[0]) if len(free) else int(np.argmin(cost))
        ha, va = aligns[k]
        far = rings[k] > LABEL_RINGS[1]
        arrow = {"arrowstyle": "-", "lw": 0.5, "color": "0.35", "shrinkA": 0, "shrinkB": 2} if far else None
        out.append(
            ax.annotate(
                text,
                anchor,
                xytext=tuple(offsets[k]),
                textcoords="offset points",
                ha=ha,
                va=va,
                fontsize=fontsize,
                arrowprops=arrow,
                gid=LABEL_GID,
                **text_kw,
            )
        )
        taken.append(boxes[k])
    return out


def label_goals(ax, spec: SceneSpec, avoid=()) -> list:
    """Each goal object's id beside its goal star (:func:`place_labels`), clear of the points ``avoid``."""
    goals = [o for o in [*spec.furniture, *spec.instruments] if o.is_goal]
    return place_labels(
        ax,
        [o.goal for o in goals],
        [o.id for o in goals],
        avoid=avoid,
        zorder=8,
        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.75},
    )


def draw_map(
    spec: SceneSpec, ax=None, show_free: bool = True, title: str | None = None, goal_labels: bool = True
):
    """Draw the scene on a matplotlib axis (created when None); returns the axis. ``goal_labels``: name the
    goals now; a caller that still adds legends or panels passes False and calls :func:`label_goals` last."""
    if ax is None:
        _, ax = map_axes(spec)
    for r in spec.rooms:
        _poly(ax, r.polygon, facecolor="#f4f4f0", edgecolor="none", zorder=0)
    if show_free:
        _draw_geom(
            ax,
            scene_free_space(spec),
            facecolor="#cfeccf",
            edgecolor="#8cc68c",
            lw=0.5,
            alpha=0.9,
            zorder=1,
            label=f"navigable (robot r = {spec.robot_radius} m)",
        )
    for w in spec.walls:
        s, e, n = np.asarray(w.start), np.asarray(w.end), np.asarray(w.interior)
        _poly(
            ax,
            [s, e, e - n * w.thickness, s - n * w.thickness],
            facecolor="#333333",
            edgecolor="#333333",
            zorder=5,
        )
    for o in spec.dressing:
        _poly(
            ax,
            o.placed().zone1_corners(),
            facecolor=DRESSING_COLOR,
            edgecolor="#6b5b3e",
            hatch="////",
            lw=0.7,
            zorder=4,
        )
    for o in [*spec.furniture, *spec.instruments]:
        p = o.placed()
        color = category_color(o.category)
        if o.is_goal:
            _poly(
                ax, p.zone3_corners(), facecolor=color, alpha=0.18, edgecolor=color, lw=1.0, ls="-", zorder=2
            )
        _poly(ax, p.zone2_corners(), facecolor="none", edgecolor="#d62728", lw=0.9, ls="--", zorder=3)
        alpha = 0.55 if o.placement == "furniture" else 0.95
        _poly(
            ax,
            p.zone1_corners(),
            facecolor=color,
            alpha=alpha,
            edgecolor="black",
            lw=0.8,
            zorder=4 if o.placement != "furniture" else 3,
        )
        if o.face is not None:
            f = np.asarray(o.face)
            start = p.center_xy + f * (o.d_half or 0.0) * 0.2
            length = (o.d_half or 0.2) * 0.8
            ax.add_patch(
                FancyArrow(
                    *start,
                    *(f * length),
                    width=0.04,
                    head_width=0.14,
                    head_length=0.12,
                    color="black",
                    zorder=6,
                )
            )
        if o.is_goal:
            g = np.asarray(o.goal)
            ax.add_patch(
                Circle(g, o.success_radius, facecolor="none", edgecolor=color, lw=1.0, ls=":", zorder=6)
            )
            ax.plot(*g, marker="*", ms=13, color=color, markeredgecolor="black", zorder=7)
    xs = [x for r in spec.rooms for x, _ in r.polygon]
    ys = [y for r in spec.rooms for _, y in r.polygon]
    ax.set_xlim(min(xs) - MAP_MARGIN, max(xs) + MAP_MARGIN)
    ax.set_ylim(min(ys) - MAP_MARGIN, max(ys) + MAP_MARGIN)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"{spec.name} ({spec.template}, seed {spec.seed})")
    ax.grid(True, lw=0.3, alpha=0.5)
    if goal_labels:
        label_goals(ax, spec)
    return ax


def legend_handles(dressing: bool = False):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    extra = [Patch(facecolor=DRESSING_COLOR, edgecolor="#6b5b3e", hatch="////", label="lab dressing")]
    return [
        Patch(facecolor="#cfeccf", edgecolor="#8cc68c", label="navigable area"),
        Patch(facecolor="#999999", edgecolor="black", label="Zone 1 (body)"),
        Line2D([], [], color="#d62728", ls="--", label="Zone 2 (0.25 m clearance)"),
        Patch(facecolor="#999999", alpha=0.2, label="Zone 3 (operation area)"),
        Line2D(
            [],
            [],
            marker="*",
            color="none",
            markerfacecolor="#999999",
            markeredgecolor="black",
            ms=12,
            label="goal (Eq. 1)",
        ),
        Line2D([], [], color="#999999", ls=":", label="success radius r"),
        *(extra if dressing else []),
    ]


ISLAND_COLORS = ["#cfeccf", "#cfe0f4", "#f4e6cf", "#eccfe9"]


def draw_islands(ax, nav) -> None:
    """Each island of the navigable area in its own colour (drawn over the single-colour area)."""
    for k, poly in enumerate(nav.islands):
        _draw_geom(
            ax, poly, facecolor=ISLAND_COLORS[k % len(ISLAND_COLORS)], edgecolor="#6a9a6a", lw=0.6, zorder=1.5
        )


def draw_episode(ax, episode: dict, path=None) -> None:
    """Start (with heading), goal, view points and the shortest path of a Habitat-style episode."""
    s = np.asarray(episode["start_position"][:2])
    w, _, _, z = episode["start_rotation"]
    yaw = 2 * np.arctan2(z, w)
    goal = episode["goals"][0]
    if path is not None and len(path):
        path = np.asarray(path)
        ax.plot(path[:, 0], path[:, 1], "-", color="#1f77b4", lw=2.2, zorder=9, label="shortest path")
    for vp in goal["view_points"]:
        p = np.asarray(vp["agent_state"]["position"][:2])
        vw, _, _, vz = vp["agent_state"]["rotation"]
        vyaw = 2 * np.arctan2(vz, vw)
        ax.add_patch(
            FancyArrow(
                *p,
                0.12 * np.cos(vyaw),
                0.12 * np.sin(vyaw),
                width=0.01,
                head_width=0.05,
                head_length=0.04,
                color="#444444",
                zorder=9,
            )
        )
    ax.add_patch(
        FancyArrow(
            *s,
            0.35 * np.cos(yaw),
            0.35 * np.sin(yaw),
            width=0.04,
            head_width=0.14,
            head_length=0.1,
            color="#1f77b4",
            zorder=10,
        )
    )
    ax.plot(*s, marker="o", ms=10, color="#1f77b4", markeredgecolor="white", zorder=11)
    ax.plot(*goal["position"][:2], marker="X", ms=11, color="#d62728", markeredgecolor="white", zorder=11)
    info = episode["info"]
    ax.set_title(
        f"{episode['scene_id']} episode {episode['episode_id']}: {episode['object_id']} - geodesic "
        f"{info['geodesic_distance']:.2f} m ({info['difficulty']})"
    )


def draw_people(ax, paths: np.ndarray) -> None:
    """People on the map: ``paths`` (people, poses, 2), each person's path as a thin line and their body (a
    disc of the person's radius) where it starts, solid, and where it ends, outlined."""
    for path in np.asarray(paths, float):
        ax.plot(path[:, 0], path[:, 1], "-", color=PERSON_COLOR, lw=1.0, alpha=0.8, zorder=8)
        ax.add_patch(
            Circle(path[0], PERSON_RADIUS, facecolor=PERSON_COLOR, edgecolor="black", lw=0.7, zorder=12)
        )
        ax.add_patch(
            Circle(path[-1], PERSON_RADIUS, facecolor="none", edgecolor=PERSON_COLOR, lw=1.2, zorder=12)
        )


def people_handles() -> list:
    """Legend entries of :func:`draw_people`."""
    from matplotlib.lines import Line2D

    return [
        Line2D([], [], marker="o", color="none", markerfacecolor=PERSON_COLOR, markeredgecolor="black", ms=9,
               label="person at the start"),
        Line2D([], [], marker="o", color="none", markerfacecolor="none", markeredgecolor=PERSON_COLOR, ms=9,
               label="... at the end"),
        Line2D([], [], color=PERSON_COLOR, lw=1.0, label="a person's path"),
    ]  # fmt: skip


def episode_handles(with_path: bool) -> list:
    """Legend entries of an episode overlay (:func:`draw_episode`)."""
    from matplotlib.lines import Line2D

    path = [Line2D([], [], color="#1f77b4", lw=2.2, label="shortest path")] if with_path else []
    return [
        Line2D([], [], marker="o", color="none", markerfacecolor="#1f77b4", markeredgecolor="white", ms=9,
               label="start (arrow: heading)"),
        Line2D([], [], marker="X", color="none", markerfacecolor="#d62728", markeredgecolor="white", ms=10,
               label="episode goal"),
        Line2D([], [], marker=">", color="none", markerfacecolor="#444444", ms=6, label="view points"),
        *path,
    ]  # fmt: skip


def legend_outside(ax, handles=None, **kw):
    """The axes' legend beside it on the right, top-aligned (:func:`fit_figure` makes room for it)."""
    kw = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0, "fontsize": 8, **kw}
    return ax.legend(handles=handles, **kw) if handles is not None else ax.legend(**kw)


def map_axes(spec: SceneSpec, width: float = MAP_WIDTH, max_height: float = MAP_MAX_HEIGHT):
    """A figure holding one axes sized to the scene's extent (``width`` inches wide, or ``max_height`` high
    for a deep scene) and filling it; :func:`fit_figure` then adds the margins its decorations need."""
    xs = [x for r in spec.rooms for x, _ in r.polygon]
    ys = [y for r in spec.rooms for _, y in r.polygon]
    aspect = (max(ys) - min(ys) + 2 * MAP_MARGIN) / (max(xs) - min(xs) + 2 * MAP_MARGIN)
    w = min(width, max_height / aspect)
    fig = plt.figure(figsize=(w, w * aspect))
    return fig, fig.add_axes((0.0, 0.0, 1.0, 1.0))


def map_figure(spec: SceneSpec, episode: dict | None = None, nav=None, people=None):
    """The map as a figure: the scene, its legend outside the axes on the right, with ``episode`` (and its
    scene's ``nav``) the islands, start, goal, view points and shortest path, with ``people`` (paths, as
    :func:`draw_people` takes them) the people; goal labels placed last and the figure fitted to its
    content."""
    fig, ax = map_axes(spec)
    draw_map(spec, ax, goal_labels=False)
    if nav is not None:
        draw_islands(ax, nav)
    path = None
    if episode is not None:
        if nav is not None:
            path = nav.shortest_path(episode["start_position"][:2], episode["goals"][0]["position"][:2])
        draw_episode(ax, episode, path)
    if people is not None:
        draw_people(ax, people)
    handles = legend_handles(bool(spec.dressing))
    handles += episode_handles(path is not None) if episode is not None else []
    handles += people_handles() if people is not None else []
    legend_outside(ax, handles)
    label_goals(ax, spec)
    fit_figure(fig)
    return fig


def save_map(
    spec: SceneSpec, out: str | Path, episode: dict | None = None, nav=None, dpi: int = 130, people=None
) -> Path:
    """Write the map PNG (:func:`map_figure`)."""
    fig = map_figure(spec, episode, nav, people)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
