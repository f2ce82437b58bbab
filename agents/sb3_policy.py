"""A Stable-Baselines3 policy (PPO, A2C or SAC trained by ``biovln-ms train``) behind the policy interface.

It reads the flat state observation of ``BioVLN-OpFace-RL-v0`` (the env it was trained on) and returns
the deterministic action: an int for PPO/A2C (Discrete(4)), a [forward, turn, stop] array for SAC.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from biovln_ms.agents.policy import EpisodeInfo, Policy
from biovln_ms.catalog import PAPER_GOAL_CATEGORIES, load_catalog
from biovln_ms.errors import BioVLNError


class SB3Policy(Policy):
    obs_mode = "state"

    def __init__(self, checkpoint: str, algo: str = "ppo", deterministic: bool = True) -> None:
        from biovln_ms.learning.sb3_safe import load_sb3_model

        path = Path(checkpoint)
        if not path.is_file():
            raise BioVLNError(
                "no such checkpoint",
                source=str(path),
                field="checkpoint",
                fix=f"train one: biovln-ms train {algo} --timesteps N --out DIR (it writes DIR/model.zip)",
            )
        self.model = load_sb3_model(path, algo)  # never unpickles: a checkpoint is untrusted input
        self.name = algo
        self.deterministic = deterministic

    def reset(self, episode_info: EpisodeInfo) -> None:
        """Nothing to reset: the network is stateless."""

    def act(self, obs, info: dict):
        x = obs.cpu().numpy()[0] if hasattr(obs, "cpu") else np.asarray(obs)[0]
        expected = self.model.observation_space.shape
        if x.shape != expected:
            fix = "evaluate on the env it was trained on (--env BioVLN-OpFace-RL-v0)"
            paper = len(PAPER_GOAL_CATEGORIES)
            if x.size - int(np.prod(expected)) == len(load_catalog().goal_categories()) - paper:
                fix = (
                    f"it was trained when the objectgoal one-hot held {paper} categories (the catalog has "
                    f"added some since): retrain it, biovln-ms train {self.name} --timesteps N --out DIR"
                )
            raise BioVLNError(
                f"the model expects observations of shape {expected}, this env gives {x.shape}",
                field="env",
                fix=fix,
            )
        action, _ = self.model.predict(x, deterministic=self.deterministic)
        return int(action) if np.ndim(action) == 0 else np.asarray(action, np.float32)
