"""Registers every navigation variant of :data:`biovln_ms.variants.VARIANTS` with ManiSkill and gymnasium.

Each id gets a subclass of :class:`~biovln_ms.tasks.nav_env.BioVLNNavEnv` (of
:class:`~biovln_ms.tasks.protocol_env.BioVLNProtocolEnv` for the protocol variants) that differs only in its
``config``, named after the id (``BioVLN-OpFace-RL-v0`` -> ``BioVLNOpFaceRLv0``) and importable from this
module, so spawned worker processes can unpickle it.
"""

from __future__ import annotations

from biovln_ms.registration import VARIANT_HOOKS, register_biovln_env
from biovln_ms.task_config import NavTaskConfig
from biovln_ms.tasks.nav_env import BioVLNNavEnv
from biovln_ms.tasks.protocol_env import BioVLNProtocolEnv
from biovln_ms.variants import VARIANTS


def register_variant_class(uid: str, cfg: NavTaskConfig) -> type:
    """The env class of variant ``uid``, registered with ManiSkill (and so gymnasium)."""
    name = "".join(ch for ch in uid if ch.isalnum())
    base = BioVLNProtocolEnv if cfg.protocol else BioVLNNavEnv
    cls = type(
        name,
        (base,),
        {
            "config": cfg,
            "__module__": __name__,
            "__qualname__": name,
            "__doc__": f"``{uid}``: {base.__doc__.splitlines()[0]}",
        },
    )
    globals()[name] = cls
    register_biovln_env(uid, max_episode_steps=cfg.max_episode_steps)(cls)
    return cls


for _uid, _cfg in VARIANTS.items():
    register_variant_class(_uid, _cfg)
VARIANT_HOOKS.append(register_variant_class)  # variants registered from now on
