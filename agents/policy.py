"""The policy interface every BioVLN baseline implements (paper §4.3): discrete actions, 500 steps."""

from __future__ import annotations

from abc import ABC, abstractmethod

STOP, FORWARD, TURN_LEFT, TURN_RIGHT = 0, 1, 2, 3


class Policy(ABC):
    """``reset(episode_info)`` once per episode, then ``act(obs, info) -> action`` each step."""

    name: str = "policy"

    @abstractmethod
    def reset(self, episode_info: dict) -> None:
        """``episode_info`` holds the episode dict and the env (``env``) for privileged policies."""

    @abstractmethod
    def act(self, obs, info: dict) -> int:
        ...
