"""LSAT import (paper §3.3 P1, §3.4): a designer-authored GLB -> a validated BioVLN scene spec.

What a designer's GLB needs (node names; Blender duplicates such as ``.001`` are fine):

- ``floor*`` meshes: each is a room; its axis-aligned footprint becomes the room rectangle, and walls
  are derived along the union of the floors (as for procedural scenes);
- instruments and goal furniture named by category as designers name them (``Refrigerator``,
  ``Fridge_02``, ``BSC-2``, ``centrifuge.001``; ``biovln_ms.lsat.names``, an optional name map first),
  or carrying ``extras.category`` (our ``scene export`` writes it); their parts may be children;
- optionally ``target_<category>`` empties: world-space goals (**strategy 1**), each given to the
  nearest instrument of its category. A marker settles the category of a mesh beside it whose name is
  ambiguous between that category and others (within MARKER_REACH); a marker with no recognised
  instrument of its category there takes the nearest unrecognised mesh as that instrument, flagged in the
  report. A name holding two categories where one names the other more specifically (``BSC cabinet``) is
  the more specific one (``biovln_ms.lsat.names``); the report lists every ambiguity so settled.

**Strategy 2** (an instrument without a marker): the footprint's minimum-area rectangle gives the centre
and the orientation; which of the four sides is the operational face is told from geometry when the
instrument has named face parts (door, handle, display, keypad, panel, sash, screen, controls): the side
they sit on; otherwise from the node's own rotation applied to the catalog's default face. The goal is
then Eq. 1, g = c + f(d + δ). Table-top instruments are put on the furniture under them at the Eq. 4
height. Sizes are the catalog's (the scene builder renders catalog assets at the designer's poses); a
measured footprint more than 5 cm off is reported.

Designer scenes keep free placement: the spec's ``template`` is ``lsat`` and only the rules a scene must
keep (catalog, Eq. 3, Eq. 4, inside rooms, goals navigable and mutually reachable) refuse it; the other
generator rules are listed as warnings in the coverage report. An import that fails collects every problem
first (each naming the designer's node and where it stands), lists them all in its error and its report,
and writes the report when asked to (``report_path``) whether it succeeds or not.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
from shapely.geometry import MultiPoint, Point, Polygon, box

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import ROBOT_RADIUS
from biovln_ms.errors import BioVLNError, one_line
from biovln_ms.geometry.zones import placement_z, rot2, wrap_angle
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.limits import ID_CHARS, ID_RULE, MAX_ID_LENGTH
from biovln_ms.lsat.gltf import GLTFScene, Node, read_gltf
from biovln_ms.lsat.names import (
    FACE_PART_WORDS,
    TARGET_PREFIX,
    Match,
    NameMap,
    is_target_marker,
    match_category,
    normalise,
)
from biovln_ms.scene.generator import rooms_from_rects
from biovln_ms.scene.loading import parse_spec
from biovln_ms.scene.rules import DESIGNER_RULES, check_consistency, check_layout
from biovln_ms.scene.spec import (
    DESIGNER_TEMPLATE,
    SCHEMA_VERSION,
    ObjectSpec,
    OpeningSpec,
    RoomSpec,
    SceneSpec,
    SceneSpecError,
    WallSpec,
    make_object,
)

SHELL_PREFIXES = ("floor", "wall", "ceiling", "room", "light", "camera")  # normalised names of no object
OBJECT_ID_PATTERN = r"[A-Za-z0-9_\-]{1,64}"  # an ``extras.object_id`` (our exporter's) kept as the id
MIN_FLOOR_SIDE = 1.0  # m: smaller floor meshes are ignored
FLOOR_LEVEL_TOLERANCE = 0.05  # m: floor tops further than this from z = 0 or from each other are reported
ROOM_DECIMALS = 4  # room rectangle corners are rounded to 0.1 mm
DEFAULT_WALL_HEIGHT = 3.0  # m, when the GLB has no wall mesh
FOOTPRINT_DECIMALS = 5  # footprint vertices are rounded to 10 um (and deduplicated) before the min-area rect
SIZE_TOLERANCE = 0.05  # m: a measured footprint side further than this from the catalog's is reported
NEAR_SQUARE = 0.1  # m: footprints closer to square than this take their axes from the node's rotation
FACE_PART_MIN_OFFSET = 0.02  # m: face parts centred closer than this to the footprint centre tell no side
SUPPORT_TOLERANCE = 0.03  # m between a table-top instrument's bottom and its support's top (or the floor)
MARKER_REACH = 1.5  # m from a marker to the footprint of the instrument it may belong to

RoomRect = tuple[str, str, tuple[float, float, float, float]]  # (room id, kind, (x0, y0, x1, y1))


class LSATImportError(BioVLNError):
    """A designer GLB that cannot become a valid scene."""


@dataclass
class ImportReport:
    source: str
    # one row per placed object: id, node, category, is_goal, goal_strategy, face_from
    instruments: list[dict] = field(default_factory=list)
    markers: list[dict] = field(default_factory=list)  # node, category, assigned_to
    unmatched: list[str] = field(default_factory=list)  # node names that matched no category
    ambiguous: list[dict] = field(default_factory=list)
    # markers whose instrument was recognised only by them: marker, node, category, distance (m)
    adopted: list[dict] = field(default_factory=list)
    # names of several categories settled: node, candidates, category, by (the more specific name, a marker)
    settled: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    # what makes the import fail: node (the designer's, or None), at ([x, y] or None), rule, message
    problems: list[dict] = field(default_factory=list)

    def problem(self, message: str, node: str | None = None, at=None, rule: str | None = None) -> None:
        """Record a problem that fails the import; the import goes on to find the others."""
        xy = None if at is None else [round(float(at[0]), 3), round(float(at[1]), 3)]
        self.problems.append({"node": node, "at": xy, "rule": rule, "message": message})

    def problem_lines(self) -> list[str]:
        """Each problem in one line: the designer's node, where it stands, what is wrong, the rule."""
        lines = []
        for p in self.problems:
            who = [f"`{p['node']}`"] if p["node"] is not None else []
            who += [f"at ({p['at'][0]:.2f}, {p['at'][1]:.2f})"] if p["at"] is not None else []
            rule = f" [rule: {p['rule']}]" if p["rule"] else ""
            lines.append(f"{' '.join(who)}: {p['message']}{rule}" if who else f"{p['message']}{rule}")
        return lines

    def coverage(self) -> dict:
        goals = [i for i in self.instruments if i["is_goal"]]
        return {
            "instruments_found": len(self.instruments),
            "goal_objects": len(goals),
            "goals_strategy1": sum(i["goal_strategy"] == 1 for i in goals),
            "goals_strategy2": sum(i["goal_strategy"] == 2 for i in goals),
            "missing": [i["id"] for i in goals if i["goal_strategy"] is None],
            "markers_unassigned": [m["node"] for m in self.markers if m.get("assigned_to") is None],
            "unmatched_names": len(self.unmatched),
            "ambiguous_names": len(self.ambiguous),
            "instruments_from_markers": [a["node"] for a in self.adopted],
            "ambiguous_settled": len(self.settled),
            "problems": len(self.problems),
        }

    def to_markdown(self) -> str:
        c = self.coverage()
        summary = (
            f"Instruments found: {c['instruments_found']} ({c['goal_objects']} goal objects); "
            f"goals from markers (strategy 1): {c['goals_strategy1']}; from geometry + Eq. 1 "
            f"(strategy 2): {c['goals_strategy2']}; missing: {len(c['missing'])}."
        )
        lines = [f"# LSAT import of `{self.source}`", ""]
        if self.problems:
            n = len(self.problems)
            lines += [f"## The import failed: {n} problem{'s' if n > 1 else ''}", ""]
            lines += [f"- {x}" for x in self.problem_lines()] + [""]
        lines += [summary, "", "| id | node | category | goal from | face from |", "|---|---|---|---|---|"]
        for i in self.instruments:
            strat = {1: "marker (strategy 1)", 2: "Eq. 1 (strategy 2)", None: "–"}[i["goal_strategy"]]
            lines.append(f"| {i['id']} | `{i['node']}` | {i['category']} | {strat} | {i['face_from']} |")
        for title, items in (
            (
                "Instruments recognised only by their marker (check them)",
                [
                    f"`{a['marker']}`: the nearest unrecognised mesh, `{a['node']}` ({a['distance']:.2f} m "
                    f"away), taken as {a['category']}; rename it or add it to the --names map to confirm"
                    for a in self.adopted
                ],
            ),
            (
                "Ambiguous names settled",
                [
                    f"`{r['node']}`: {' or '.join(r['candidates'])} -> {r['category']} ({r['by']})"
                    for r in self.settled
                ],
            ),
            ("Markers without an instrument", c["markers_unassigned"]),
            ("Names matching no category", self.unmatched),
            (
                "Ambiguous names (not guessed)",
                [f"`{a['node']}`: {', '.join(a['candidates'])}" for a in self.ambiguous],
            ),
            ("Warnings", self.warnings),
        ):
            if items:
                lines += ["", f"## {title}", ""] + [f"- {x}" for x in items]
        return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class _Found:
    """A node of a catalog category, with the world points of its subtree (its parts)."""

    node: Node
    category: str
    points: np.ndarray


class _Marker(NamedTuple):
    """A ``target_<category>`` node: a designer's world-space goal (strategy 1); ``instrument``, the node
    name of the instrument it was given when only it told that instrument's category."""

    node: Node
    category: str
    instrument: str | None = None


class _Ambiguous(NamedTuple):
    """A node whose name says several categories (``candidates``), with the world points of its subtree:
    a marker of one of them beside it settles which."""

    node: Node
    candidates: tuple[str, ...]
    points: np.ndarray


class _Classified(NamedTuple):
    """What the non-shell nodes are: objects to place, markers to assign, the nodes that are neither
    (reported as unmatched), and the ambiguous ones a marker may settle."""

    found: list[_Found]
    markers: list[_Marker]
    loose: list[Node]
    ambiguous: tuple[_Ambiguous, ...] = ()


class _Footprint(NamedTuple):
    """The minimum-area rectangle around a footprint: centre, direction of its first side, side lengths."""

    centre: np.ndarray
    theta: float
    a: float
    b: float


class _Pose(NamedTuple):
    """Where an object stands: its footprint box's centre (x, y), its yaw, and what told the face."""

    centre: np.ndarray
    yaw: float
    face_from: str


class _Shell(NamedTuple):
    """The rooms, the walls along their union and the openings where they meet (``rooms_from_rects``)."""

    rooms: list[RoomSpec]
    walls: list[WallSpec]
    openings: list[OpeningSpec]


class _Placed(NamedTuple):
    """Placed objects and their coverage rows (``ImportReport.instruments``), keyed by object id."""

    furniture: list[ObjectSpec]
    instruments: list[ObjectSpec]
    rows: dict[str, dict]

    def objects(self) -> list[ObjectSpec]:
        return [*self.furniture, *self.instruments]


def _footprint(points: np.ndarray) -> _Footprint | None:
    """The min-area rectangle of the points' (x, y); None when it is degenerate (a point or a line)."""
    xy = np.unique(np.round(points[:, :2], FOOTPRINT_DECIMALS), axis=0)
    rect = MultiPoint([tuple(p) for p in xy]).minimum_rotated_rectangle
    if not isinstance(rect, Polygon):
        return None
    c = np.asarray(rect.exterior.coords)[:4]
    e1, e2 = c[1] - c[0], c[2] - c[1]
    return _Footprint(
        np.asarray(rect.centroid.coords[0]),
        math.atan2(e1[1], e1[0]),
        float(np.linalg.norm(e1)),
        float(np.linalg.norm(e2)),
    )


def _face_parts(scene: GLTFScene, node: Node) -> np.ndarray:
    """Vertices of the parts whose names say they are on the operational face, with their own children
    (a nested part counted once)."""
    on_face = {
        m.index
        for n in scene.subtree(node)[1:]
        if any(w in normalise(n.name) for w in FACE_PART_WORDS)
        for m in scene.subtree(n)
    }
    pts = [p for p in (scene.mesh_points(scene.nodes[i]) for i in sorted(on_face)) if len(p)]
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def _resolve_yaw(scene: GLTFScene, f: _Found, fp: _Footprint) -> tuple[float, str]:
    """The yaw that puts the catalog's model axes on the footprint's sides and its face where it is.

    The rectangle's sides give the axes up to 180 deg; for a near-square footprint (a round bin) they
    say nothing, so the node's own rotation gives them. The face parts (or, without them, the node's
    rotation and the catalog's default face) then pick the side."""
    cat = load_catalog().get(f.category)
    w, d = cat.dimensions[0], cat.dimensions[1]
    x_axis = f.node.world[:3, :3] @ np.array([1.0, 0.0, 0.0])
    node_yaw = math.atan2(x_axis[1], x_axis[0])
    if abs(w - d) < NEAR_SQUARE:
        candidates = [wrap_angle(node_yaw + k * math.pi / 2) for k in range(4)]
    else:
        aligned = abs(fp.a - w) + abs(fp.b - d) <= abs(fp.a - d) + abs(fp.b - w)
        base = fp.theta if aligned else fp.theta + math.pi / 2
        candidates = [wrap_angle(base), wrap_angle(base + math.pi)]
    if cat.face_vector is None:
        return candidates[0], "no face (catalog)"
    parts = _face_parts(scene, f.node)
    if len(parts):
        offset = parts[:, :2].mean(0) - fp.centre
        if np.linalg.norm(offset) > FACE_PART_MIN_OFFSET:
            scores = [float(np.dot(rot2(y) @ cat.face_vector, offset)) for y in candidates]
            return candidates[int(np.argmax(scores))], "geometry (face parts)"
    diffs = [abs(wrap_angle(y - node_yaw)) for y in candidates]
    return candidates[int(np.argmin(diffs))], "node rotation (catalog face)"


def _is_floor(name: str) -> bool:
    """'Floor', 'floor_lab.001', or a floor part under a shell node ('room_shell/shell.floor_lab')."""
    return re.search(r"(^|_)floor", normalise(re.split(r"[/|]", name)[-1])) is not None


def _category(node: Node, names: NameMap | None) -> Match:
    """The node's catalog category: its ``extras.category`` when that names one (our exporter writes it),
    else what its name says (``biovln_ms.lsat.names``)."""
    cat = node.extras.get("category")
    if isinstance(cat, str) and cat in load_catalog():
        return Match(node.name, cat, cat, 0)
    return match_category(node.name, names=names)


def _rooms(scene: GLTFScene, report: ImportReport) -> tuple[list[RoomRect], float]:
    """The rooms (one per ``floor*`` mesh: its axis-aligned footprint) and the wall height (the highest
    ``wall*`` mesh, else DEFAULT_WALL_HEIGHT); no usable floor is a problem (no rooms)."""
    floors = [n for n in scene.nodes if _is_floor(n.name)]
    rects, tops = [], []
    for n in floors:
        pts = scene.subtree_points(n)
        if len(pts) < 3:
            report.warnings.append(f"floor node '{n.name}' has no mesh: ignored")
            continue
        x0, y0 = pts[:, :2].min(0)
        x1, y1 = pts[:, :2].max(0)
        if x1 - x0 < MIN_FLOOR_SIDE or y1 - y0 < MIN_FLOOR_SIDE:
            report.warnings.append(
                f"floor node '{n.name}' is smaller than {MIN_FLOOR_SIDE:g} x {MIN_FLOOR_SIDE:g} m: ignored"
            )
            continue
        corners = tuple(round(float(v), ROOM_DECIMALS) for v in (x0, y0, x1, y1))
        rects.append((f"room_{len(rects)}", "room", corners))
        tops.append(float(pts[:, 2].max()))
    if not rects:
        report.problem(
            f"no floor: no mesh node named 'floor...' of at least {MIN_FLOOR_SIDE:g} x {MIN_FLOOR_SIDE:g} m "
            "(name the floor mesh 'floor', one per room: 'floor_lab', 'floor_corridor')"
        )
        return [], DEFAULT_WALL_HEIGHT
    if max(tops) - min(tops) > FLOOR_LEVEL_TOLERANCE or abs(min(tops)) > FLOOR_LEVEL_TOLERANCE:
        report.warnings.append(
            f"floor tops range {min(tops):.3f}..{max(tops):.3f} m: BioVLN assumes the floor at z = 0"
        )
    walls = [n for n in scene.nodes if normalise(n.name).startswith("wall")]
    heights = [pts[:, 2].max() for pts in (scene.subtree_points(n) for n in walls) if len(pts)]
    return rects, float(max(heights)) if heights else DEFAULT_WALL_HEIGHT


def _marker(node: Node, report: ImportReport, names: NameMap | None) -> _Marker | None:
    """A ``target_*`` node's marker; a category name matching none or several is reported instead."""
    m = match_category(node.name, TARGET_PREFIX, names)
    if m.ambiguous:
        report.ambiguous.append({"node": node.name, "candidates": list(m.candidates)})
    elif m.category is None:
        report.unmatched.append(node.name)
    else:
        _settled(report, node.name, m)
        return _Marker(node, m.category)
    return None


def _settled(report: ImportReport, node: str, m: Match) -> None:
    """Report a name of several categories that the more specific one settled."""
    if m.set_aside:
        candidates = sorted({m.category, *m.set_aside})
        report.settled.append(
            {"node": node, "candidates": candidates, "category": m.category, "by": "the more specific name"}
        )


def _preorder(scene: GLTFScene) -> list[Node]:
    """The nodes parents first, children in their listed order (the file's own order when it is already a
    tree order; Blender's exporter lists children before their parents)."""
    out, stack = [], [n.index for n in reversed(scene.nodes) if n.parent is None]
    while stack:
        node = scene.nodes[stack.pop()]
        out.append(node)
        stack.extend(reversed(node.children))
    return out


def _classify(scene: GLTFScene, report: ImportReport, names: NameMap | None = None) -> _Classified:
    """Sort the nodes (the room shell, lights and cameras aside) into markers and objects of a catalog
    category; an object (matched or ambiguous) claims its subtree as its parts, and so does a node the name
    map calls no instrument. Names matching no category (the loose nodes), or several (never guessed), and
    objects without a mesh are reported; the ambiguous ones with a mesh are kept for the markers."""
    found: list[_Found] = []
    markers: list[_Marker] = []
    loose: list[Node] = []
    ambiguous: list[_Ambiguous] = []
    claimed: set[int] = set()
    for n in _preorder(scene):
        if n.parent in claimed:
            claimed.add(n.index)
            continue
        if normalise(n.name).startswith(SHELL_PREFIXES) or _is_floor(n.name):
            continue
        if is_target_marker(n.name):
            if (marker := _marker(n, report, names)) is not None:
                markers.append(marker)
            continue
        m = _category(n, names)
        if m.ambiguous or (m.category is None and m.how == "name map"):
            if m.ambiguous:
                report.ambiguous.append({"node": n.name, "candidates": list(m.candidates)})
                if len(pts := scene.subtree_points(n)) >= 3:
                    ambiguous.append(_Ambiguous(n, m.candidates, pts))
            claimed.add(n.index)
            continue
        if m.category is None:
            if n.mesh is not None or n.children:
                report.unmatched.append(n.name)
                loose.append(n)
            continue
        pts = scene.subtree_points(n)
        claimed.add(n.index)
        if len(pts) < 3:
            report.warnings.append(f"'{n.name}' ({m.category}) has no mesh: skipped")
            continue
        _settled(report, n.name, m)
        found.append(_Found(n, m.category, pts))
    return _Classified(found, markers, loose, tuple(ambiguous))


def _hull_distance(points: np.ndarray, xy: np.ndarray) -> float:
    """Distance in the floor plane from ``xy`` to the footprint (convex hull) of ``points``."""
    return MultiPoint([tuple(p) for p in points[:, :2]]).convex_hull.distance(Point(xy))


def _adopt(scene: GLTFScene, c: _Classified, report: ImportReport) -> tuple[list[_Found], list[_Marker]]:
    """A marker settles the nearest ambiguous node within MARKER_REACH whose candidates hold its category
    (unless a recognised instrument of that category is nearer): the node is an instrument of the marker's
    category, moved in the report from the ambiguous names to the settled ones. A marker with no
    instrument of its category within MARKER_REACH takes the nearest loose node there (the topmost one
    holding neither a recognised or ambiguous object nor a marker) as that instrument; the report flags
    it, and the node and its parts leave ``report.unmatched``."""
    found, markers = list(c.found), []
    taken = {m.index for f in found for m in scene.subtree(f.node)}
    taken |= {m.index for a in c.ambiguous for m in scene.subtree(a.node)}
    taken |= {m.node.index for m in c.markers}
    pool = list(c.ambiguous)
    groups: list[tuple[Node, np.ndarray]] = []
    inside: set[int] = set()
    for n in c.loose:
        sub = {m.index for m in scene.subtree(n)}
        if n.index in inside or sub & taken:
            continue
        inside |= sub
        if len(pts := scene.subtree_points(n)) >= 3:
            groups.append((n, pts))
    for mk in c.markers:
        xy = mk.node.origin[:2]
        near = [
            f for f in found if f.category == mk.category and _hull_distance(f.points, xy) <= MARKER_REACH
        ]
        settle = [
            (_hull_distance(a.points, xy), k) for k, a in enumerate(pool) if mk.category in a.candidates
        ]
        settle = [(d, k) for d, k in settle if d <= MARKER_REACH]
        if settle and min(settle)[0] < min((_hull_distance(f.points, xy) for f in near), default=math.inf):
            d, k = min(settle)
            a = pool.pop(k)
            found.append(_Found(a.node, mk.category, a.points))
            markers.append(mk._replace(instrument=a.node.name))
            report.ambiguous[:] = [x for x in report.ambiguous if x["node"] != a.node.name]
            by = f"marker `{mk.node.name}`, {d:.2f} m away"
            report.settled.append(
                {"node": a.node.name, "candidates": list(a.candidates), "category": mk.category, "by": by}
            )
            continue
        dist = [(_hull_distance(pts, xy), k) for k, (_, pts) in enumerate(groups)]
        if near or not dist or min(dist)[0] > MARKER_REACH:
            markers.append(mk)
            continue
        d, k = min(dist)
        node, pts = groups.pop(k)
        found.append(_Found(node, mk.category, pts))
        markers.append(mk._replace(instrument=node.name))
        parts = {m.name for m in scene.subtree(node)}
        report.unmatched[:] = [u for u in report.unmatched if u not in parts]
        report.adopted.append(
            {"marker": mk.node.name, "node": node.name, "category": mk.category, "distance": round(d, 3)}
        )
    return found, markers


def _pose(scene: GLTFScene, f: _Found, report: ImportReport) -> _Pose | None:
    """The object's pose from its footprint; None (reported) for a degenerate footprint. Sizes stay the
    catalog's; a measured footprint more than SIZE_TOLERANCE off is reported."""
    fp = _footprint(f.points)
    if fp is None:
        report.warnings.append(f"'{f.node.name}' has a degenerate footprint: skipped")
        return None
    yaw, face_from = _resolve_yaw(scene, f, fp)
    local = f.points[:, :2] @ rot2(yaw)  # rows: R(-yaw) p, the footprint in the instrument's own axes
    lo, hi = local.min(0), local.max(0)
    measured = sorted(hi - lo)
    a = load_catalog().get(f.category)
    if max(abs(x - y) for x, y in zip(measured, sorted(a.dimensions[:2]))) > SIZE_TOLERANCE:
        report.warnings.append(
            f"'{f.node.name}': footprint {measured[1]:.2f} x {measured[0]:.2f} m differs "
            f"from the catalog's {a.dimensions[0]:.2f} x {a.dimensions[1]:.2f} m "
            "(the catalog's is used)"
        )
    return _Pose(rot2(yaw) @ ((lo + hi) / 2), yaw, face_from)


def _rest(
    f: _Found, centre: np.ndarray, furniture: list[ObjectSpec], report: ImportReport
) -> tuple[str | None, float] | None:
    """The support and centre height: a table-top instrument is snapped onto the furniture under its centre
    at the Eq. 4 height (none there is a problem: None); anything else stands on the floor. A bottom more
    than SUPPORT_TOLERANCE off is reported."""
    cat = load_catalog()
    a = cat.get(f.category)
    bottom = float(f.points[:, 2].min())
    if a.placement != "table_top":
        if abs(bottom) > SUPPORT_TOLERANCE:
            report.warnings.append(
                f"'{f.node.name}': bottom at {bottom:.3f} m above the floor (snapped to the floor)"
            )
        return None, a.dimensions[2] / 2
    sup = next((o for o in furniture if o.placed().zone1().contains(Point(centre))), None)
    if sup is None:
        report.problem(
            f"a table-top {f.category} standing on no bench or table (put it on a 'Lab Bench' or 'Lab "
            "Table' node)",
            f.node.name,
            centre,
        )
        return None
    top = cat.support_heights[sup.category]
    if abs(bottom - top) > SUPPORT_TOLERANCE:
        report.warnings.append(
            f"'{f.node.name}': bottom at {bottom:.3f} m, its support's top at {top:.3f} m (snapped, Eq. 4)"
        )
    return sup.id, placement_z(top, 0.0, -a.dimensions[2] / 2)


def _object_id(f: _Found, taken: dict[str, dict], counts: Counter) -> str:
    """The node's ``extras.object_id`` (our exporter's ids survive a round trip) when valid and free, else the
    first free ``<category>_<n>``."""
    obj_id = f.node.extras.get("object_id")
    if isinstance(obj_id, str) and re.fullmatch(OBJECT_ID_PATTERN, obj_id) and obj_id not in taken:
        return obj_id
    while f"{f.category}_{counts[f.category]}" in taken:
        counts[f.category] += 1
    return f"{f.category}_{counts[f.category]}"


def _place(scene: GLTFScene, found: list[_Found], rects: list[RoomRect], report: ImportReport) -> _Placed:
    """Pose, room, support and id of each found object: furniture first (the supports), each kind in tree
    order. Goal objects get their Eq. 1 goal here; an object outside every floor or a table-top one on no
    support is a problem, and left out."""
    cat = load_catalog()
    floor_boxes = {rid: box(*rect) for rid, _, rect in rects}
    placed = _Placed([], [], {})
    counts: Counter = Counter()
    for f in sorted(found, key=lambda f: (cat.get(f.category).placement != "furniture", f.node.index)):
        pose = _pose(scene, f, report)
        if pose is None:
            continue
        room = next((rid for rid, poly in floor_boxes.items() if poly.contains(Point(pose.centre))), None)
        if room is None:
            report.problem(
                f"a {f.category} standing outside every floor (move it onto a floor mesh, or add a floor "
                "under it)",
                f.node.name,
                pose.centre,
            )
            continue
        rest = _rest(f, pose.centre, placed.furniture, report)
        if rest is None:
            continue
        support, z = rest
        obj_id = _object_id(f, placed.rows, counts)
        a = cat.get(f.category)
        flag = f.node.extras.get("is_goal")  # our exporter says which furniture is a goal; else the catalog
        is_goal = flag if isinstance(flag, bool) else a.goal_category
        obj = make_object(
            cat, obj_id, f.category, pose.centre, z, pose.yaw, a.placement, room, support, None, is_goal
        )
        (placed.furniture if a.placement == "furniture" else placed.instruments).append(obj)
        placed.rows[obj_id] = {
            "id": obj_id,
            "node": f.node.name,
            "category": f.category,
            "is_goal": is_goal,
            "goal_strategy": None,
            "face_from": pose.face_from,
        }
    return placed


def _assign_markers(placed: _Placed, markers: list[_Marker], report: ImportReport) -> _Placed:
    """Strategy 1: each marker is the goal of the nearest goal object of its category (a second marker for
    one object is ignored, reported); strategy 2: the other goal objects keep their Eq. 1 goal. Fills
    ``report.markers`` and ``report.instruments``."""
    by_id = {o.id: o for o in placed.objects()}
    rows = {k: dict(v) for k, v in placed.rows.items()}
    for node, category, instrument in markers:
        xy = node.origin[:2]
        cands = [
            o
            for o in by_id.values()
            if o.category == category and o.is_goal and instrument in (None, rows[o.id]["node"])
        ]
        rec = {"node": node.name, "category": category, "assigned_to": None}
        if cands:
            o = min(cands, key=lambda o: math.dist(o.position[:2], xy))
            if rows[o.id]["goal_strategy"] == 1:
                report.warnings.append(f"marker '{node.name}': '{o.id}' already has a marker; ignored")
            else:
                goal = (float(xy[0]), float(xy[1]))
                by_id[o.id] = o.model_copy(update={"goal": goal, "goal_source": "marker"})
                rows[o.id]["goal_strategy"] = 1
                rec["assigned_to"] = o.id
        report.markers.append(rec)
    for row in rows.values():
        if row["is_goal"] and row["goal_strategy"] is None:
            row["goal_strategy"] = 2
    report.instruments = list(rows.values())
    return _Placed([by_id[o.id] for o in placed.furniture], [by_id[o.id] for o in placed.instruments], rows)


def _assemble(
    name: str, shell: _Shell, placed: _Placed, robot_radius: float, report: ImportReport
) -> SceneSpec | None:
    """The designer scene spec, checked against the catalog and the layout rules: each broken designer rule
    (``DESIGNER_RULES``) is a problem naming the designer's node, the other generator rules are report
    warnings. None (a problem) when there is no instrument or the spec breaks its schema."""

    cat = load_catalog()
    if not placed.instruments:
        report.problem(f"no instrument found (name instrument nodes by category: {', '.join(cat.names())})")
        return None
    obj = {
        "schema_version": SCHEMA_VERSION,
        "name": name,
        "template": DESIGNER_TEMPLATE,
        "seed": 0,
        "generator_version": 0,
        "robot_radius": robot_radius,
        "catalog_sha256": cat.sha256,
        "rooms": [r.model_dump() for r in shell.rooms],
        "walls": [w.model_dump() for w in shell.walls],
        "openings": [o.model_dump() for o in shell.openings],
        "furniture": [o.model_dump() for o in placed.furniture],
        "instruments": [o.model_dump() for o in placed.instruments],
    }
    try:
        spec = parse_spec(obj, source=report.source)
    except SceneSpecError as e:
        report.problem(f"the imported scene is not a valid spec: field '{e.field}': {e.message}")
        return None
    nodes = {row["id"]: row["node"] for row in placed.rows.values()}
    broken = [v for v in check_consistency(spec) if v.rule in DESIGNER_RULES]
    if not broken:  # the layout rules assume objects that agree with the catalog
        for v in check_layout(spec):
            if v.rule in DESIGNER_RULES:
                broken.append(v)
            else:
                report.warnings.append(f"generator rule '{v.rule}': {v.message}")
    for v in broken:
        report.problem(v.message, nodes.get(v.objects[0]) if v.objects else None, rule=v.rule)
    return spec


def _failure(report: ImportReport, report_path: Path | None) -> LSATImportError:
    """The import's error: every problem in one line, numbered, and where the report lists them."""
    lines = report.problem_lines()
    n = len(lines)
    listed = lines[0] if n == 1 else "; ".join(f"{i}) {x}" for i, x in enumerate(lines, 1))
    where = f"; the report {report_path} lists them" if report_path is not None else ""
    return LSATImportError(
        f"{n} problem{'s' if n > 1 else ''}: {listed}",
        source=report.source,
        fix=f"move, rename or add the named nodes in the authoring tool{where}",
    )


def name_as_id(text: str) -> str:
    """An id made of ``text`` (``My Lab (v2)`` -> ``My_Lab_v2``): each run of other characters one ``_``."""
    out = re.sub(r"[^A-Za-z0-9_.\-]+", "_", text).lstrip("_.-")[:MAX_ID_LENGTH].rstrip("_.-")
    return out or "scene"


def scene_name(path: Path, name: str | None) -> str:
    """The imported scene's name: ``name``, else the GLB's file name without its suffix. It names the scene's
    files, so it must be an id; one that is not is refused in one line suggesting an id for ``--name``
    (``name=``), before the GLB is read."""
    value = path.stem if name is None else name
    if isinstance(value, str) and len(value) <= MAX_ID_LENGTH and re.fullmatch(ID_CHARS, value):
        return value
    text = str(value)
    suggestion = name_as_id(text)
    shown = one_line(repr(text), 60)
    given = name is not None
    what = f"scene name {shown}" if given else f"the GLB's file name {shown} (the default scene name)"
    rename = "" if given else ", or rename the file"
    raise LSATImportError(
        f"{what} is not an id",
        source=str(path),
        field="--name",
        fix=f"pass --name {suggestion} (name= in Python){rename}; a scene name is {ID_RULE}",
    )


def import_glb(
    path: str | Path,
    name: str | None = None,
    allow_external: bool = False,
    robot_radius: float = ROBOT_RADIUS,
    names: NameMap | None = None,
    report_path: str | Path | None = None,
) -> tuple[SceneSpec, ImportReport]:
    """Read, interpret and validate a designer GLB: rooms, classify (``names``: the user's name map, which
    wins), settle ambiguous names and adopt instruments for orphan markers, place, assign markers,
    assemble. The spec keeps the designer rules; the report says where each goal came from. Every problem
    found fails the import at the end, all of them in one ``LSATImportError``; ``report_path``: the
    Markdown report is written there whether the import succeeds or fails (else nothing is written)."""

    path = Path(path)
    report_path = None if report_path is None else Path(report_path)
    report = ImportReport(str(path))
    try:
        name = scene_name(path, name)
        scene = read_gltf(path, allow_external=allow_external)
        rects, wall_height = _rooms(scene, report)
        if not rects:
            raise _failure(report, report_path)
        shell = _Shell(*rooms_from_rects(rects, wall_height))
        found, markers = _adopt(scene, _classify(scene, report, names), report)
        placed = _assign_markers(_place(scene, found, rects, report), markers, report)
        spec = _assemble(name, shell, placed, robot_radius, report)
        if report.problems:
            raise _failure(report, report_path)
        return spec, report
    except BioVLNError as e:
        if not report.problems:  # the GLB itself could not be read
            report.problem(e.message)
        raise
    finally:
        if report_path is not None:
            atomic_write_text(report_path, report.to_markdown())
