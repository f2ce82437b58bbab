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
        obs, info = env.reset(options={"episode_index": episode})
        u = env.unwrapped
        pol = make_policy(policy)
        pol.reset({"env": u, "episode": u.current_episode})
        canvas = MapCanvas(u.scene_spec, size[1], goal=u._ctx.goal)
        trail = [u._planar()[:2].copy()]
        frames = []

        def frame(o):
            ego = o["sensor_data"]["head"]["rgb"][0].cpu().numpy()
            return side_by_side(ego, canvas.frame(trail, u._planar()))

        frames.append(frame(obs))
        for _ in range(max_steps):
            a = pol.act(obs, info)
            obs, _, term, trunc, info = env.step(a)
            trail.append(u._planar()[:2].copy())
            frames.append(frame(obs))
            if bool(term) or bool(trunc):
                break
        write_mp4(frames, out, fps=fps)
        return {k: (v.item() if hasattr(v, "item") else v) for k, v in info.items() if k != "reconfigure"}
    finally:
        env.close()
