"""The Stable-Baselines3 algorithms this package trains, and the env they train and evaluate on."""

from biovln_ms.errors import BioVLNError

# the env control mode each needs: SAC acts in a continuous Box ([forward, turn, stop] in [-1, 1]),
# PPO and A2C in Discrete(4)
SB3_CONTROL_MODES = {"ppo": "discrete", "a2c": "discrete", "sac": "continuous"}


def algo_class(name: str):
    """The Stable-Baselines3 class of ``name``."""
    from stable_baselines3 import A2C, PPO, SAC

    classes = {"ppo": PPO, "a2c": A2C, "sac": SAC}
    if name not in classes:
        raise BioVLNError(
            f"unknown algorithm '{name}'", field="algo", fix=f"use one of: {', '.join(SB3_CONTROL_MODES)}"
        )
    return classes[name]
