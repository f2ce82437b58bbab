"""Run one episode with a policy and write an MP4: egocentric RGB beside the top-down map (with people, they
are drawn on it as they walk)."""

from __future__ import annotations

from pathlib import Path

from biovln_ms.eval.methods import method_spec
from biovln_ms.eval.rollout import rollout
from biovln_ms.variants import BENCHMARK_ENV


def record_episode(
    out: Path,
    split: str | None = "ms_val",
    episode: int = 0,
    policy: str = "oracle",
    dataset: str | None = None,
    env_id: str = BENCHMARK_ENV,
    size: tuple[int, int] = (640, 480),
    fps: int = 5,
    lighting: str = "fast",
    gaps: bool = False,
) -> dict:
    """Record one episode; returns its final metrics, and with ``gaps`` (an env with people) each frame's
    ``person_distance`` under ``"gaps"`` (which frame shows people nearest)."""
    import gymnasium as gym

    from biovln_ms.render.video import MapCanvas, side_by_side, write_mp4

    env = gym.make(
        env_id,
        split=split,
        dataset=dataset,
        obs_mode="rgbd",
        camera_width=size[0],
        camera_height=size[1],
        sim_backend="physx_cpu",
        render_backend="cpu",
        lighting=lighting,
    )
    try:
        spec = method_spec(policy)
        frames, trail, people, canvas, distances = [], [], [], None, []
        for st in rollout(env, spec.factory(), episode, spec.privileged):
            pose = st.info["agent_pose"][0].cpu().numpy()
            if canvas is None:
                canvas = MapCanvas(
                    env.unwrapped.scene_spec, size[1], goal=st.info["goal_position"][0].cpu().numpy()
                )
            trail.append(pose[:2].copy())
            crowd = env.unwrapped.get_state_dict()["task"].get("people")  # an env with people: theirs
            if crowd is not None:
                people.append(crowd["pos"][0].cpu().numpy()[crowd["present"][0].cpu().numpy() > 0.5])
                distances.append(float(st.info["person_distance"][0]))
            ego = st.obs["sensor_data"]["head"]["rgb"][0].cpu().numpy()
            frames.append(side_by_side(ego, canvas.frame(trail, pose, people)))
            info = st.info
        write_mp4(frames, out, fps=fps)
        final = {
            k: (v.item() if hasattr(v, "item") else v)
            for k, v in info.items()
            if k != "reconfigure" and getattr(v, "numel", lambda: 1)() == 1
        }
        return {**final, "gaps": distances} if gaps else final
    finally:
        env.close()
