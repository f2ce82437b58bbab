"""Protocol language agent: reads the instruction, finds the objects it names on its own map, and visits
them in order with the frontier machinery (``BioVLN-Protocol-v0``).

It reads the instruction from the observation (``instruction_text``, else the ``instruction`` tokens), never
the goal sensors: the parser (:func:`biovln_ms.protocols.parser.parse_targets`, offline and the default, or
an LLM through :class:`LLMInstructionParser`) gives the ordered (category, relation) targets. It keeps one
map over the whole protocol:

* the frontier agent's occupancy grid from depth, and its nearest-frontier exploration;
* **detections**: every frame, each goal category's pixels of the ``semantic_category`` sensor (the GT
  detector: a frame counts for a category with at least 150 of its pixels at 640 x 480, as VLFM's),
  back-projected with depth onto a 0.1 m grid per category; an **instance** is a connected group of
  those cells (cells within 0.3 m joined);
* **walls**: depth points from 0.15 m above the catalog's tallest asset up to 2.9 m (rooms are at least
  3.0 m high), which only walls reach, on the same 0.1 m grid.

The current target (``info["subgoal_index"]``, which advances at each correct STOP, says which one) is
resolved against the instances of its category (a bench or a table, 2 m or longer in the catalog, once 70 %
of its length is seen: a part seen from its end is no place to stand). Without a relation the largest
instance is meant. A relation is only written where the category occurs more than once, so the agent explores
until it has detected two instances, then picks among them (with no frontier left, among what it has):

* ``in room B`` / ``in room 3``: rooms are the lettered or numbered rooms in the lab's order, west to east
  (the templates' convention); the agent's rooms are the connected known-free areas of its map once the
  wall grid's gaps up to 1.6 m (doorways) are closed, those narrower than 2.5 m being corridors;
* ``on the <support> ...``: the instance nearest the support, itself resolved the same way;
* ``by the <dir> wall``: the instance with a wall cell nearest beyond it along that direction;
* ``nearest the door``: the instance nearest a doorway cell (a gap the closing filled);
* ``to the <left|right> of the <instrument>``: the nearest instance within 3 m on that side of the
  reference, as seen by a person in front of it (its front as below);
* ``farthest <dir>``: the extreme instance along that direction.

It goes to a standing cell at the instance: 0.6 m out from its front, when it can tell one (instruments face
the room with their back to a wall: of the compass sides with free floor before them, along the axis the
catalog's footprint gives when the points show its longer side, the one with a wall nearest behind it, in the
wall grid or on the floor map beside it, else the longest run of free floor), else the reachable free cell
nearest the instance (VLFM's rule), at least 0.4 m from it, and STOPs there as the frontier agent stops at
its goal (out of the grown obstacles by the planner's escape rule after a STOP close to an instrument,
:mod:`~biovln_ms.baselines.frontier.planner`). With nothing of the category
detected and no frontier left it STOPs where it stands. ``episode_stats`` holds the parsed targets, the
instance gone to for each, and the parser's use of the LLM.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from biovln_ms.baselines.frontier import FrontierParams, FrontierPolicy, backproject, to_numpy
from biovln_ms.baselines.frontier.control import FrontierController
from biovln_ms.baselines.frontier.occupancy import FREE, OCCUPIED
from biovln_ms.baselines.frontier.planner import FrontierPlanner, PlanField, disk
from biovln_ms.baselines.policy import STOP, EpisodeInfo
from biovln_ms.baselines.protocol.chain import subgoal_index
from biovln_ms.catalog import load_catalog
from biovln_ms.constants import MAX_VISITS
from biovln_ms.errors import BioVLNError
from biovln_ms.llm.client import JSONChatClient, default_cache_path
from biovln_ms.protocols.instructions import COMPASS
from biovln_ms.protocols.parser import InstructionParseError, ParsedTarget, parse_relation, parse_targets
from biovln_ms.protocols.vocabulary import decode_text, load_vocabulary

CELL = 0.1  # m: the detection and wall grids
PIXEL_STRIDE = 4  # image rows and columns sampled for detections and walls
MIN_PIXELS = 150  # at 640 x 480: a category's pixels for a frame to count (the GT detector's rule)
MIN_HITS = 2  # frames that saw a category (or a wall) in a cell for the cell to count
JOIN_CELLS = 1  # dilation (cells) joining an instance's cells: cells within 0.3 m are one instance
WALL_ABOVE = 0.15  # m: wall points lie this far above the catalog's tallest asset ...
WALL_TOP = 2.9  # m: ... and below this (the templates' rooms are at least 3.0 m high, to the ceiling)
DOOR_CLOSING = 8  # cells: closing radius of the wall grid, filling doorways up to 1.6 m wide
WALL_MARGIN = 3  # cells: free cells this near a wall belong to no room (an instance is labelled by its side)
MIN_REGION = 150  # cells (1.5 m^2): a smaller free area is no room
CORRIDOR_WIDTH = 2.5  # m: a region whose shorter side is narrower is a corridor, not a room
FRONT_RUN = 3.0  # m: the longest free run looked for out from an instance
FRONT_MIN = 0.5  # m: a front needs at least this much known free floor before it
NEAR_WALL = 1.0  # m: an instance with a wall this near behind one side faces away from it
FLANK = 0.4  # m: beside an instance, where a wall behind it shows on the floor map
SPAN_MARGIN = 0.15  # m: points spanning more than a footprint's shorter side by this show its longer one
STAND_OFF = 0.4  # m: the least distance kept from the instance when standing at it
LONG_FURNITURE, SEEN_SHARE = 2.0, 0.7  # m, share: furniture this long is gone to once this much is seen
FRONT = 0.6  # m: the standing point in front of an instance, beyond its points
FRONT_SLACK = 0.75  # m: the farthest the standing cell may lie from that point
SIDE_RANGE = 3.0  # m: the farthest a "left/right of" reference may be
WALL_RANGE = 3.0  # m: how far along a direction a wall is looked for
SYSTEM = (
    "You read a laboratory worker's instruction to a mobile robot and list, in order, the instruments it "
    'must visit. Answer with a JSON object {"targets": [{"category": C, "relation": R}, ...]}: C is one of '
    "the categories given; R is null when the instruction names the instrument alone, else the phrase that "
    "singles it out, worded exactly as one of: 'in room X', 'in the <room>', 'on the <support>' (optionally "
    "followed by 'in room X' or 'farthest <direction>'), 'by the <north|south|east|west> wall', 'nearest "
    "the door', 'to the <left|right> of the <instrument>', 'farthest <north|south|east|west>'. What the "
    "worker does at an instrument is no visit."
)


class LLMInstructionParser:
    """Targets from an OpenAI-compatible LLM (``biovln_ms.llm.client.JSONChatClient``); its answer must name
    goal categories and relations of the grammar (:func:`parse_relation`). A failed or invalid answer falls
    back to the rule parser (counted in ``fallbacks``), or with ``fallback=False`` raises
    :class:`InstructionParseError`."""

    def __init__(self, client=None, fallback: bool = True) -> None:
        if client is None:  # as `eval` builds it: the endpoint from the environment, the persistent cache
            client = JSONChatClient(cache_path=default_cache_path())
        self.client, self.fallback = client, fallback
        self.consulted = self.fallbacks = 0

    def _targets(self, answer: dict, categories: tuple[str, ...]) -> list[ParsedTarget]:
        items = answer["targets"]
        if not isinstance(items, list) or not 1 <= len(items) <= MAX_VISITS:
            raise ValueError("targets must be a list of 1 to 5 visits")
        out = []
        for t in items:
            if t["category"] not in categories:
                raise ValueError(f"unknown category {t['category']!r}")
            rel = t.get("relation")
            out.append(ParsedTarget(t["category"], None if rel is None else parse_relation(rel, categories)))
        return out

    def parse(self, text: str, categories: tuple[str, ...]) -> list[ParsedTarget]:
        """The instruction's ordered targets."""
        self.consulted += 1
        stats = getattr(self.client, "stats", None)
        before = dict(stats.failure_kinds) if stats is not None else {}
        answer = self.client.ask(
            SYSTEM,
            json.dumps({"categories": list(categories), "instruction": text}),
            validate=lambda o: bool(self._targets(o, categories)),
        )
        if answer is not None:
            return self._targets(answer, categories)
        if not self.fallback:
            after = stats.failure_kinds if stats is not None else {}
            kinds = sorted(k for k in after if after[k] > before.get(k, 0))
            raise InstructionParseError(
                f"the LLM gave no valid target list ({', '.join(kinds) or 'no answer'})",
                field="parser",
                fix="check the endpoint (BIOVLN_LLM_BASE_URL, BIOVLN_LLM_MODEL, BIOVLN_LLM_API_KEY), or use "
                "parser='rule'",
            )
        self.fallbacks += 1
        return parse_targets(text, categories)


@dataclass
class Instance:
    """A detected object: its cells' world centres (M, 2) and their centroid."""

    points: np.ndarray

    @property
    def centroid(self) -> np.ndarray:
        return self.points.mean(axis=0)

    @property
    def size(self) -> int:
        return len(self.points)

    def distance(self, xy: np.ndarray) -> float:
        return float(np.min(np.linalg.norm(self.points - xy, axis=1)))


def _count_frame(grid: np.ndarray, flat: np.ndarray) -> None:
    """One more frame for each cell of ``grid`` (by flat index) among ``flat``, saturating."""
    cells = np.unique(flat)
    view = grid.reshape(-1)
    view[cells] = np.minimum(view[cells].astype(np.int64) + 1, np.iinfo(grid.dtype).max)


def _largest(instances: list[Instance]) -> Instance | None:
    return max(instances, key=lambda i: i.size, default=None)


class ProtocolLanguagePolicy(FrontierPolicy):
    """Instruction-following on the frontier machinery (see the module docstring)."""

    name = "protocol_language"
    obs_mode = "depth+segmentation"

    def __init__(self, parser="rule", params: FrontierParams | None = None) -> None:
        """``parser``: "rule" (offline, the default), "llm" (the LLM client of the environment's endpoint),
        or any object with ``parse(text, categories) -> list[ParsedTarget]``."""
        super().__init__(params)
        if parser not in ("rule", "llm") and not hasattr(parser, "parse"):
            raise InstructionParseError(
                f"unknown parser {parser!r}", field="parser", fix="use parser='rule' or parser='llm'"
            )
        self.parser = LLMInstructionParser() if parser == "llm" else parser

    def reset(self, episode_info: EpisodeInfo) -> None:
        super().reset(episode_info)
        self.categories = tuple(episode_info.task.goal_categories)
        assets = load_catalog().assets()
        self.wall_low = max(a.dimensions[2] for a in assets) + WALL_ABOVE
        # the catalog's footprints: (width of the face, depth behind it), m
        self.footprints = {
            a.name: (a.dimensions[1], a.dimensions[0]) if "X" in (a.face or "") else a.dimensions[:2]
            for a in assets
        }
        self.targets: list[ParsedTarget] | None = None
        self.leg = 0
        self.watched: list[str] = []  # the categories the instruction names (targets, supports, references)
        self.hits: np.ndarray | None = None  # (watched, n, n) frames that saw each category in each cell
        self.walls: np.ndarray | None = None  # (n, n) frames that saw a wall in each cell
        self.resolved: list[list[float] | None] = []  # per leg, the instance centroid gone to

    # --- the instruction -----------------------------------------------------------------------
    def _instruction(self, obs) -> str:
        extra = obs["extra"]
        if "semantic_category" not in extra:
            raise BioVLNError(
                "the language agent detects with the semantic_category sensor, which this observation lacks",
                field="obs_mode",
                fix="make the env with obs_mode='depth+segmentation'",
            )
        if "instruction_text" not in extra and "instruction" not in extra:
            raise BioVLNError(
                "the language agent reads the instruction, which this observation lacks",
                field="env_id",
                fix="run it on BioVLN-Protocol-v0 (a protocol_* split)",
            )
        if "instruction_text" in extra:
            return decode_text(to_numpy(extra["instruction_text"][0]))
        return load_vocabulary().decode(to_numpy(extra["instruction"][0]))

    def _parse(self, text: str) -> list[ParsedTarget]:
        if self.parser == "rule":
            return parse_targets(text, self.categories)
        return self.parser.parse(text, self.categories)

    # --- steps ---------------------------------------------------------------------------------
    def _start(self, obs, pose: np.ndarray) -> None:
        """First step: the map, planner and controller, the targets from the instruction and empty
        detection and wall grids (no goal sensor is read)."""
        self._build(pose)
        self._new_leg()
        self.targets = self._parse(self._instruction(obs))
        self.resolved = [None] * len(self.targets)
        named = [t.category for t in self.targets]
        named += [t.relation.category for t in self.targets if t.relation and t.relation.category]
        self.watched = sorted(set(named))
        n = round(self.params.extent / CELL)
        self.origin = self.map.origin
        self.hits = np.zeros((len(self.watched), n, n), np.uint16)
        self.walls = np.zeros((n, n), np.uint16)

    def act(self, obs, info: dict) -> int:
        j = subgoal_index(info)
        if self.map is not None and j != self.leg:  # the last STOP was correct (or a miss): the next target
            self.leg = j
            self._new_leg()
        if self.targets is not None and self.leg >= len(self.targets):
            return STOP  # the instruction named fewer visits than the episode has
        return super().act(obs, info)

    def _new_leg(self) -> None:
        """A new planner and controller on the map kept so far."""
        self.planner = FrontierPlanner(self.people_params(self.params), self)
        turn = math.radians(self.task.turn_deg)
        p = self.control.params
        self.control = FrontierController(p, self.task.forward_step, turn, self.map, self.planner)

    def _integrate(self, obs):
        scan = super()._integrate(obs)
        self._detect(obs)
        return scan

    def _cells(self, xy: np.ndarray) -> np.ndarray:
        """(row, col) on the 0.1 m grids of world points (..., 2)."""
        return np.floor((xy - self.origin) / CELL).astype(int)[..., ::-1]

    def _centres(self, rc: np.ndarray) -> np.ndarray:
        return self.origin + (rc[..., ::-1] + 0.5) * CELL

    def _detect(self, obs) -> None:
        """This frame's points of every goal category, and of the walls, onto the grids."""
        depth, intrinsic, extrinsic = self._frame(obs)
        semantic = to_numpy(obs["extra"]["semantic_category"][0, ..., 0])
        h, w = depth.shape
        v, u = np.mgrid[PIXEL_STRIDE // 2 : h : PIXEL_STRIDE, PIXEL_STRIDE // 2 : w : PIXEL_STRIDE]
        z, label = depth[v, u], semantic[v, u].astype(int)
        valid = (z > 0) & (z <= self.params.depth_clip)
        pw, _ = backproject(z[valid], u[valid], v[valid], intrinsic, extrinsic)
        rc, label = self._cells(pw[:, :2]), label[valid]
        n = self.walls.shape[0]
        flat = np.where((rc >= 0).all(1) & (rc < n).all(1), rc[:, 0] * n + rc[:, 1], -1)
        wall = (flat >= 0) & (pw[:, 2] >= self.wall_low) & (pw[:, 2] <= WALL_TOP)
        _count_frame(self.walls, flat[wall])
        enough = MIN_PIXELS * semantic.size / (640 * 480)
        counts = np.bincount(semantic.reshape(-1).astype(int), minlength=len(self.categories) + 1)
        for c, category in enumerate(self.watched):
            index = self.categories.index(category) + 1
            if counts[index] >= enough:
                _count_frame(self.hits[c], flat[(flat >= 0) & (label == index)])

    # --- what the map holds --------------------------------------------------------------------
    def instances(self, category: str) -> list[Instance]:
        """The detected objects of ``category``, largest first."""
        if category not in self.watched:
            return []
        grid = self.hits[self.watched.index(category)] >= MIN_HITS
        rows, cols = np.nonzero(grid)
        if not len(rows):
            return []
        lo = np.array([rows.min(), cols.min()]) - JOIN_CELLS - 1
        crop = grid[lo[0] : rows.max() + JOIN_CELLS + 2, lo[1] : cols.max() + JOIN_CELLS + 2]
        labels, k = ndimage.label(ndimage.binary_dilation(crop, iterations=JOIN_CELLS), np.ones((3, 3)))
        own = labels[crop]
        cells = np.argwhere(crop) + lo
        out = [Instance(self._centres(cells[own == i])) for i in range(1, k + 1)]
        return sorted(out, key=lambda i: -i.size)

    def _wall_cells(self) -> np.ndarray:
        return self.walls >= MIN_HITS

    def facing(self, inst: Instance, category: str) -> np.ndarray | None:
        """The instance's front, a compass direction: of the sides with at least ``FRONT_MIN`` of known free
        floor out from its points (along the axis the catalog's footprint says, when the points span more
        than its shorter side: its face is that long, or that deep), the one with a wall nearest behind it
        (within ``NEAR_WALL``: a cell of the wall grid, which holds no instrument, or obstacles on both of
        its flanks), else the one with the longest free run; None when no side has ``FRONT_MIN`` of free
        floor."""
        dirs = [np.array(d, float) for d in COMPASS.values()]
        span = inst.points.max(axis=0) - inst.points.min(axis=0)
        width, depth = self.footprints[category]
        if span.max() + CELL > min(width, depth) + SPAN_MARGIN:  # the long dimension seen along this axis
            axis = int(np.argmax(span))
            dirs = [d for d in dirs if (d[axis] != 0) == (depth > width)]
        runs = {tuple(d): self._free_run(inst, d) for d in dirs}
        open_ = [d for d in dirs if runs[tuple(d)] >= FRONT_MIN]
        behind = {tuple(d): min(self._wall_distance(inst, -d), self._flanked(inst, -d)) for d in open_}
        backed = [d for d in open_ if behind[tuple(d)] <= NEAR_WALL]
        if backed:
            return min(backed, key=lambda d: behind[tuple(d)])
        return max(open_, key=lambda d: runs[tuple(d)], default=None)

    def _free_run(self, inst: Instance, direction: np.ndarray) -> float:
        """How far the occupancy map is known free along ``direction`` from just beyond the instance's
        farthest point that way (up to ``FRONT_RUN``)."""
        occ = self.map
        edge = inst.centroid + direction * (float(np.max((inst.points - inst.centroid) @ direction)) + CELL)
        for s in np.arange(0.0, FRONT_RUN, occ.res):
            rc = occ.cell(edge + s * direction)
            if not ((rc >= 0).all() and (rc < occ.n).all()) or occ.grid[rc[0], rc[1]] != FREE:
                return float(s)
        return FRONT_RUN

    def _flanked(self, inst: Instance, direction: np.ndarray) -> float:
        """How far along ``direction`` beyond the instance's farthest point that way an obstacle stands on
        both of its flanks (``FLANK`` m beside its points, across the direction): a wall running behind it
        (inf: not on both within ``NEAR_WALL``)."""
        occ, across = self.map, np.array([-direction[1], direction[0]])
        reach = float(np.max((inst.points - inst.centroid) @ direction))
        side = float(np.max(np.abs((inst.points - inst.centroid) @ across))) + FLANK
        hits = []
        for sign in (1.0, -1.0):
            start = inst.centroid + across * sign * side + direction * reach
            for s in np.arange(0.0, NEAR_WALL, occ.res):
                rc = occ.cell(start + s * direction)
                if (rc >= 0).all() and (rc < occ.n).all() and occ.grid[rc[0], rc[1]] == OCCUPIED:
                    hits.append(float(s))
                    break
        return max(hits) if len(hits) == 2 else math.inf

    def _wall_distance(self, inst: Instance, direction: np.ndarray) -> float:
        """How far along ``direction`` from the instance's farthest point that way the first wall cell
        lies (inf: none within ``WALL_RANGE``)."""
        walls, n = self._wall_cells(), self.walls.shape[0]
        edge = inst.centroid + direction * float(np.max((inst.points - inst.centroid) @ direction))
        for s in np.arange(0.0, WALL_RANGE, CELL / 2):
            rc = self._cells(edge + s * direction)
            if (rc >= 0).all() and (rc < n).all() and walls[rc[0], rc[1]]:
                return float(s)
        return math.inf

    def rooms(self) -> tuple[np.ndarray, np.ndarray, list[int], list[int], np.ndarray]:
        """The map's rooms: a label grid over a crop (0: none), the crop's first cell, the room labels in
        the lab's order (west to east), the corridor labels, and the doorway cells (world centres)."""
        occ = self.map
        r0, c0 = (occ.lo // 2) - DOOR_CLOSING
        r1, c1 = (occ.hi + 1) // 2 + DOOR_CLOSING
        lo = np.maximum([r0, c0], 0)
        walls = self._wall_cells()[lo[0] : r1, lo[1] : c1]
        free_fine = occ.grid[lo[0] * 2 : r1 * 2, lo[1] * 2 : c1 * 2] == FREE
        free = np.zeros(walls.shape, bool)
        fr, fc = np.nonzero(free_fine)
        free[np.minimum(fr // 2, walls.shape[0] - 1), np.minimum(fc // 2, walls.shape[1] - 1)] = True
        closed = ndimage.binary_closing(walls, disk(DOOR_CLOSING))
        doors = closed & ~ndimage.binary_dilation(walls) & free
        space = free & ~ndimage.binary_dilation(closed, iterations=WALL_MARGIN)
        labels, k = ndimage.label(space)
        rooms, corridors, centres = [], [], {}
        for i, sl in enumerate(ndimage.find_objects(labels), 1):
            area = int(np.count_nonzero(labels[sl] == i))
            if area < MIN_REGION:
                labels[labels == i] = 0
                continue
            short = min(sl[0].stop - sl[0].start, sl[1].stop - sl[1].start) * CELL
            (corridors if short < CORRIDOR_WIDTH else rooms).append(i)
            centres[i] = np.argwhere(labels == i)[:, 1].mean()
        rooms.sort(key=lambda i: centres[i])
        return labels, lo, rooms, corridors, self._centres(np.argwhere(doors) + lo)

    def _room_of(self, inst: Instance, labels: np.ndarray, lo: np.ndarray) -> int:
        """The label of the room region nearest the instance's centroid (0: none)."""
        if not labels.any():
            return 0
        _, (ri, ci) = ndimage.distance_transform_edt(labels == 0, return_indices=True)
        rc = np.clip(self._cells(inst.centroid) - lo, 0, np.array(labels.shape) - 1)
        return int(labels[ri[rc[0], rc[1]], ci[rc[0], rc[1]]])

    # --- resolving a target ----------------------------------------------------------------------
    def resolve(self, target: ParsedTarget, final: bool = False) -> Instance | None:
        """The detected instance the target means, or None while it cannot be told (``final``: no frontier
        is left, so the best guess among what was detected)."""
        found = self.instances(target.category)
        if not final:  # a long piece of furniture seen only in part may extend away from its points
            found = [i for i in found if self._whole(i, target.category)]
        rel = target.relation
        if rel is None or len(found) == 1 and final:
            return _largest(found)
        if len(found) < 2:
            return None
        pick = self._by_relation(found, rel)
        return pick if pick is not None or not final else _largest(found)

    def _whole(self, inst: Instance, category: str) -> bool:
        """Whether the instance is seen whole enough to stand before: a category whose catalog footprint is
        ``LONG_FURNITURE`` m or longer (a bench, a table) must span ``SEEN_SHARE`` of that length."""
        length = max(self.footprints[category])
        span = inst.points.max(axis=0) - inst.points.min(axis=0)
        return length < LONG_FURNITURE or float(span.max()) + CELL >= SEEN_SHARE * length

    def _by_relation(self, found: list[Instance], rel) -> Instance | None:
        if rel.kind == "extreme":
            d = np.array(COMPASS[rel.direction])
            return max(found, key=lambda i: float(i.centroid @ d))
        if rel.kind == "wall":
            d = np.array(COMPASS[rel.direction])
            dist = [self._wall_distance(i, d) for i in found]
            return found[int(np.argmin(dist))] if np.isfinite(min(dist)) else None
        if rel.kind == "support":
            support = self.resolve(ParsedTarget(rel.category, rel.support), final=True)
            return None if support is None else min(found, key=lambda i: support.distance(i.centroid))
        if rel.kind == "side":
            ref = _largest(self.instances(rel.category))
            front = None if ref is None else self.facing(ref, rel.category)
            if front is None:
                return None
            left = np.array([front[1], -front[0]])  # a person in front of ref, facing it: its left
            sign = 1.0 if rel.direction == "left" else -1.0
            side = [
                i
                for i in found
                if sign * float((i.centroid - ref.centroid) @ left) > 0
                and np.linalg.norm(i.centroid - ref.centroid) <= SIDE_RANGE
            ]
            return min(side, key=lambda i: np.linalg.norm(i.centroid - ref.centroid), default=None)
        labels, lo, rooms, corridors, doors = self.rooms()
        if rel.kind == "door":
            if not len(doors):
                return None
            return min(found, key=lambda i: float(np.min(np.linalg.norm(doors - i.centroid, axis=1))))
        k = rel.room_ordinal  # a room
        if k is None:
            wanted = corridors if "corridor" in rel.room else rooms
        else:
            wanted = rooms[k : k + 1]
        inside = [i for i in found if self._room_of(i, labels, lo) in wanted]
        return _largest(inside)

    def standing_cell(self, inst: Instance, category: str, field: PlanField) -> np.ndarray | None:
        """Where to stop at the instance: in front of it when its front can be told, else the reachable
        cell nearest it, at least ``STAND_OFF`` from it where such cells exist (room to plan the next leg
        from); None when no cell is reachable."""
        world = field.reachable_centres()
        if not len(world):
            return None
        points = inst.points[:: max(1, inst.size // 200)]
        gap = np.min(np.linalg.norm(world[:, None, :] - points[None], axis=2), axis=1)
        if np.any(gap >= STAND_OFF):
            world, gap = world[gap >= STAND_OFF], gap[gap >= STAND_OFF]
        front = self.facing(inst, category)
        if front is not None:
            reach = float(np.max((inst.points - inst.centroid) @ front))
            d = np.linalg.norm(world - (inst.centroid + front * (reach + FRONT)), axis=1)
            if d.min() <= FRONT_SLACK:
                return world[int(np.argmin(d))]
        return world[int(np.argmin(gap))]

    # --- target rules (overrides of the frontier policy's) ------------------------------------
    def known_target(self, field: PlanField) -> np.ndarray | None:
        """The current target's standing cell, once the target is resolved on the map."""
        inst = self.resolve(self.targets[self.leg])
        if inst is None:
            return None
        self.resolved[self.leg] = [round(float(v), 3) for v in inst.centroid]
        return self.standing_cell(inst, self.targets[self.leg].category, field)

    def exhausted(self, field: PlanField, pose: np.ndarray) -> np.ndarray:
        """No frontier left: the best guess among the detected instances, else where it stands."""
        inst = self.resolve(self.targets[self.leg], final=True)
        if inst is not None:
            self.resolved[self.leg] = [round(float(v), 3) for v in inst.centroid]
        cell = None if inst is None else self.standing_cell(inst, self.targets[self.leg].category, field)
        return pose[:2] if cell is None else cell

    def episode_stats(self) -> dict:
        """The parsed targets, the instance gone to per target, the LLM's use, and the pose estimates."""
        out = {
            "targets": [list(t.pair()) for t in self.targets or []],
            "resolved": self.resolved,
            **super().episode_stats(),
        }
        if isinstance(self.parser, LLMInstructionParser):
            out.update(llm_consulted=self.parser.consulted, llm_fallbacks=self.parser.fallbacks)
        return out
