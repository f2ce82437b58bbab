"""Top-down map of a scene spec (PNG): walls, furniture, Zones 1/2/3, face arrows, goals with their
success radii, and the robot's navigable area. Episodes can be overlaid (start, goal, path)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, FancyArrow, Polygon as MplPolygon  # noqa: E402

from biovln_ms.catalog import load_catalog  # noqa: E402
from biovln_ms.scene.rules import scene_free_space  # noqa: E402
from biovln_ms.scene.spec import SceneSpec  # noqa: E402

DRESSING_COLOR = "#c8b89a"  # lab dressing: bodies in the way, no zones
UNKNOWN_COLOR = "#999999"  # a category the catalog lacks


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


def draw_map(spec: SceneSpec, ax=None, show_free: bool = True, title: str | None = None):
    """Draw the scene on a matplotlib axis (created when None); returns the axis."""
    if ax is None:
        _, ax = plt.subplots(figsize=(9, 7))
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
            ax.annotate(o.id, g, xytext=(4, 6), textcoords="offset points", fontsize=7, zorder=8)
    xs = [x for r in spec.rooms for x, _ in r.polygon]
    ys = [y for r in spec.rooms for _, y in r.polygon]
    ax.set_xlim(min(xs) - 0.4, max(xs) + 0.4)
    ax.set_ylim(min(ys) - 0.4, max(ys) + 0.4)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"{spec.name} ({spec.template}, seed {spec.seed})")
    ax.grid(True, lw=0.3, alpha=0.5)
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


def save_map(spec: SceneSpec, out: str | Path, episode: dict | None = None, nav=None, dpi: int = 130) -> Path:
    """Write the map PNG; with ``episode`` (and its scene's ``nav``) overlay islands, start, goal,
    view points and the shortest path."""
    fig, ax = plt.subplots(figsize=(10, 8))
    draw_map(spec, ax)
    if nav is not None:
        draw_islands(ax, nav)
    if episode is not None:
        path = None
        if nav is not None:
            path = nav.shortest_path(episode["start_position"][:2], episode["goals"][0]["position"][:2])
        draw_episode(ax, episode, path)
    ax.legend(
        handles=legend_handles(bool(spec.dressing)), loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8
    )
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
