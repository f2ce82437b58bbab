"""The people of a navigation env (``gym.make(..., people=N)``): one :class:`~biovln_ms.people.crowd.Crowd`
per sub-env and their SAPIEN figures, as a component the env calls from its hooks (docs/guides/people.md).

A figure is one kinematic actor of visual shapes only (legs, torso, arms, head in scrub colours, inside the
person's disc of :data:`~biovln_ms.people.body.PERSON_RADIUS`): the cameras see it in RGB and depth, and a
segmentation image's ``semantic_category`` reads :meth:`EnvPeople.category` on it. It has no collision
shape: the robot is stopped at a person's body by the model (:meth:`EnvPeople.cut`, called by the
locomotion controller), so the contact is exact and replayable and people are moved without pushing.
"""

from __future__ import annotations


import numpy as np
import sapien
import torch
from mani_skill.utils.structs.pose import Pose

from biovln_ms.people.body import PERSON_HEIGHT, PeopleStep
from biovln_ms.people.crowd import Crowd, CrowdError, stations, step_seconds

#: m: an absent person's figure is kept this far below the floor, out of every camera's sight
ABSENT_Z = -10.0

#: (half size x, y, z, centre x, y, z, colour) of a figure's boxes, in its frame (x ahead, z up), metres
_SCRUBS, _TROUSERS, _SKIN = (0.16, 0.42, 0.72), (0.12, 0.13, 0.18), (0.86, 0.66, 0.52)
_BOXES = (
    (0.06, 0.065, 0.42, 0.0, 0.085, 0.42, _TROUSERS),  # legs
    (0.06, 0.065, 0.42, 0.0, -0.085, 0.42, _TROUSERS),
    (0.10, 0.13, 0.30, 0.0, 0.0, 1.14, _SCRUBS),  # torso
    (0.045, 0.03, 0.30, 0.0, 0.16, 1.12, _SCRUBS),  # arms
    (0.045, 0.03, 0.30, 0.0, -0.16, 1.12, _SCRUBS),
)
_HEAD = (0.11, PERSON_HEIGHT - 0.11, _SKIN)  # radius, centre height, colour


def _material(rgb) -> sapien.render.RenderMaterial:
    return sapien.render.RenderMaterial(base_color=[*rgb, 1.0], roughness=0.8)


class EnvPeople:
    """The people of every sub-env of ``env`` (a :class:`~biovln_ms.tasks.nav_env.BioVLNNavEnv`)."""

    def __init__(self, env) -> None:
        self.env, n, p = env, env.num_envs, env.cfg.people
        self.crowds = [Crowd(p) for _ in range(n)]
        self.hit = np.zeros(n, dtype=bool)
        self._placed = np.full((n, p, 3), np.nan)  # each figure's last placed (x, y, yaw) per sub-env
        self._stale = False  # people moved since their figures were placed (``sync``)
        self.seconds = step_seconds(env.cfg.forward_step, env.cfg.turn_deg)
        self.actors = [self._figure(k) for k in range(p)]  # one actor per person, batched over sub-envs
        self.label = len(env.category_names) + 1  # a person's semantic category: after the goal categories
        env._segmentation_lookup = self.category(env._segmentation_lookup, self.label)

    def _figure(self, k: int):
        b = self.env.scene.create_actor_builder()
        for hx, hy, hz, x, y, z, rgb in _BOXES:
            b.add_box_visual(sapien.Pose([x, y, z]), half_size=[hx, hy, hz], material=_material(rgb))
        radius, z, rgb = _HEAD
        b.add_sphere_visual(sapien.Pose([0.0, 0.0, z]), radius=radius, material=_material(rgb))
        b.initial_pose = sapien.Pose([0.0, 0.0, ABSENT_Z])
        return b.build_kinematic(name=f"person_{k}")

    def category(self, lookup: torch.Tensor, value: int) -> torch.Tensor:
        """``lookup`` (segmentation id -> semantic category) with every figure's ids mapped to ``value``."""
        ids = [int(i) for a in self.actors for i in np.atleast_1d(a.per_scene_id.cpu().numpy())]
        out = torch.zeros(max([len(lookup) - 1, *ids]) + 1, dtype=lookup.dtype, device=lookup.device)
        out[: len(lookup)] = lookup
        out[ids] = value
        return out

    # --- the hooks' share ----------------------------------------------------------------------------
    def reset(self, rows: list[int], pose: np.ndarray) -> PeopleStep:
        """New crowds for sub-envs ``rows`` (their episodes just began, the robots at ``pose``); the people
        of every sub-env. An episode carrying its own crowd (a busy split's) brings its count and crowd
        seed; any other has ``people=`` people drawn from the sub-env's episode seed."""
        e = self.env
        for i in rows:
            spec, nav = e.scene_specs[i], e.navs[i]
            st = stations(spec, nav, pose[i, :2])
            own = e._episodes[i].get("people")
            count, seed = (own["count"], own["seed"]) if own else (None, int(e._episode_seed[i]))
            try:
                self.crowds[i].reset(nav, st, pose[i, :2], e._footprint, seed, spec.name, count)
            except CrowdError as err:
                if not own:
                    raise
                raise CrowdError(  # the count is the episode's: it is the dataset that is wrong
                    f"episode {e._episodes[i]['episode_id']} of scene '{spec.name}' brings {count} "
                    f"people: {err.message}",
                    field="people.count",
                    fix="rebuild the dataset (biovln-ms dataset build), or pass people=0 for an empty lab",
                ) from None
        self.hit[rows] = False
        self._placed[rows] = np.nan  # a new episode's figures are placed whatever they were
        self._stale = True
        return self._view(np.zeros(e.num_envs))

    def cut(self, i: int, x: float, y: float, tx: float, ty: float) -> tuple[float, float]:
        """Sub-env ``i``'s robot move target cut at a person's body (the controller's swept check)."""
        tx, ty, hit = self.crowds[i].cut(x, y, tx, ty)
        self.hit[i] |= hit
        return tx, ty

    def step(self, pose: np.ndarray, frozen: np.ndarray) -> PeopleStep:
        """After the robots' moves (at ``pose``): the people of sub-envs still running move for a step."""
        wait = np.zeros(self.env.num_envs)
        for i in np.flatnonzero(~frozen).tolist():
            wait[i] = self.crowds[i].advance(self.seconds, pose[i, :2])
        self._stale = True
        out = self._view(wait)
        self.hit[:] = False
        return out

    def _view(self, wait: np.ndarray) -> PeopleStep:
        positions = np.array([c.pos for c in self.crowds])  # (N, P, 2), a copy
        return PeopleStep(positions, self.hit.copy(), wait, self.env._footprint, self.seconds)

    def sync(self) -> None:
        """Place the figures where their people are, if they moved since (the env calls it before anything
        renders and before its state is read: a state-only step never pays for the figures)."""
        if self._stale:
            self._place(list(range(self.env.num_envs)))
            self._stale = False

    def _place(self, rows: list[int]) -> None:
        """The figures of sub-envs ``rows`` where their people are (on the GPU, rows are the sub-envs being
        reset, or all of them); a figure none of whose rows moved since it was last placed is left as is."""
        now = np.stack([np.column_stack([self.crowds[i].pos, self.crowds[i].yaw]) for i in rows])  # (r, P, 3)
        if np.array_equal(now, self._placed[rows]):  # nobody moved (standing people, an ended episode)
            return
        present = np.stack([self.crowds[i].present for i in rows])
        for k, actor in enumerate(self.actors):
            if np.array_equal(now[:, k], self._placed[rows, k]):  # NaN (never placed) is never equal
                continue
            p = np.column_stack([now[:, k, :2], np.where(present[:, k], 0.0, ABSENT_Z)])
            half = now[:, k, 2] / 2
            q = np.column_stack([np.cos(half), np.zeros((len(rows), 2)), np.sin(half)])
            if self.env.gpu_sim_enabled:
                dev = self.env.device
                actor.pose = Pose.create_from_pq(
                    torch.from_numpy(p).float().to(dev), torch.from_numpy(q).float().to(dev)
                )
            else:  # each sub-scene's entity directly (ManiSkill's batched setter costs more than the people)
                for j, i in enumerate(rows):
                    actor._objs[i].pose = sapien.Pose(p[j].astype(np.float32), q[j].astype(np.float32))
            self._placed[rows, k] = now[:, k]
        if self.env.gpu_sim_enabled:
            self.env.scene.px.gpu_apply_rigid_dynamic_data()

    def view(self, i: int):
        """What an oracle's privileged view reads of sub-env ``i``'s people: a function giving the centres
        of those in its episode now (copies)."""
        return lambda: self.crowds[i].pos[self.crowds[i].present]  # boolean indexing copies

    # --- state ---------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, torch.Tensor]:
        """Every crowd's state, stacked over sub-envs, as float64 (integers exact; the figures' poses are
        ManiSkill's actor state)."""
        states = [c.state() for c in self.crowds]
        return {
            k: torch.from_numpy(np.stack([s[k] for s in states]).astype(np.float64)).to(self.env.device)
            for k in Crowd.STATE
        }

    def load_state_dict(self, state: dict, rows: np.ndarray) -> None:
        self._placed[rows] = np.nan  # the figures' poses come back with ManiSkill's actor state
        self._stale = True
        for i in rows.tolist():
            self.crowds[i].load({k: torch.as_tensor(state[k]).cpu().numpy()[i] for k in Crowd.STATE})
