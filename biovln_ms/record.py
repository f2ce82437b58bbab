"""Run one episode with a policy and write an MP4: egocentric RGB beside the top-down map."""

from __future__ import annotations

from pathlib import Path



def make_policy(name: str):
    from biovln_ms.eval.methods import method_spec

    return method_spec(name).factory()


def record_episode(out: Path, split: str | None = "ms_val", episode: int = 0, policy: str = "oracle",
                   dataset: str | None = None, env_id: str = "BioVLN-OpFace-v0", size: tuple[int, int] = (640, 480),
                   fps: int = 5, max_steps: int = 500) -> dict:
    """Record one episode; returns its final metrics."""
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.render.video import MapCanvas, side_by_side, write_mp4

    env = gym.make(env_id, split=split, dataset=dataset, obs_mode="rgbd", camera_width=size[0], camera_height=size[1],
                   sim_backend="physx_cpu", render_backend="cpu")
    try:
        from biovln_ms.eval.rollout import rollout

        u = env.unwrapped
        frames, trail, canvas = [], [], None
        for st in rollout(env, make_policy(policy), episode, max_steps):
            if canvas is None:
                canvas = MapCanvas(u.scene_spec, size[1], goal=u._ctx.goal)
            trail.append(u._planar()[:2].copy())
            ego = st.obs["sensor_data"]["head"]["rgb"][0].cpu().numpy()
            frames.append(side_by_side(ego, canvas.frame(trail, u._planar())))
            info = st.info
        write_mp4(frames, out, fps=fps)
        return {k: (v.item() if hasattr(v, "item") else v) for k, v in info.items() if k != "reconfigure"}
    finally:
        env.close()
