"""The measures of a task, batched over ``num_envs``: the torch boundary of :mod:`biovln_ms.metrics.measures`
(``info`` tensors, state dicts on the env's device)."""

from __future__ import annotations

import numpy as np
import torch

from biovln_ms.metrics.measures import _REGISTRY, BatchContext, Measure, Rows, StepState
from biovln_ms.task_config import NavTaskConfig


class MeasureSet:
    """Registered measures for ``n`` sub-envs, updated in dependency order; ``device`` is where the torch
    views (:meth:`info`, :meth:`tensor`, :meth:`state_dict`) go."""

    def __init__(
        self,
        names: tuple[str, ...] = NavTaskConfig().measures,
        n: int = 1,
        device: torch.device | str = "cpu",
        cfg: NavTaskConfig | None = None,
    ) -> None:
        order: list[str] = []
        present: set[str] = set()  # the measures and their dependencies, all of them

        def close(name: str) -> None:
            if name not in _REGISTRY:
                raise KeyError(f"unknown measure '{name}'; registered: {', '.join(_REGISTRY)}")
            if name not in present:
                present.add(name)
                for d in _REGISTRY[name].dependencies:
                    close(d)

        def visit(name: str, stack: tuple = ()) -> None:
            if name in order:
                return
            if name in stack:
                raise ValueError(f"measure dependency cycle: {' -> '.join(stack + (name,))}")
            cls = _REGISTRY[name]
            for d in cls.dependencies + tuple(a for a in cls.after if a in present):
                visit(d, stack + (name,))
            order.append(name)

        for name in names:
            close(name)
        for name in names:
            visit(name)
        self.names, self.n, self.device = tuple(names), n, torch.device(device)
        cfg = cfg or NavTaskConfig()
        self.measures = {name: _REGISTRY[name](n, cfg) for name in order}
        self._info_dtype = {name: self._info_type(meas) for name, meas in self.measures.items()}

    def __getitem__(self, name: str) -> np.ndarray:
        """The live values of measure ``name`` (host array; do not modify)."""
        return self.measures[name].value

    def tensor(self, name: str, dtype: torch.dtype | None = None) -> torch.Tensor:
        """A copy of measure ``name``'s values as a tensor on the device."""
        t = torch.from_numpy(self.measures[name].value.copy())  # a fifth of torch.tensor's cost on the CPU
        return t.to(self.device, dtype) if dtype is not None or self.device.type != "cpu" else t

    @staticmethod
    def _idx(env_idx: torch.Tensor | np.ndarray | None) -> Rows:
        """Rows to touch: a slice for all of them (basic indexing is cheaper than an index array)."""
        if env_idx is None:
            return slice(None)
        return env_idx.cpu().numpy() if isinstance(env_idx, torch.Tensor) else np.asarray(env_idx)

    def reset(self, ctx: BatchContext, state: StepState, env_idx: torch.Tensor | None = None) -> None:
        """Start the episodes of sub-envs ``env_idx`` (all by default)."""
        idx = self._idx(env_idx)
        for meas in self.measures.values():
            meas.reset(ctx, state, self, idx)

    def update(self, ctx: BatchContext, state: StepState, env_idx: torch.Tensor | None = None) -> None:
        """One step of sub-envs ``env_idx`` (all by default)."""
        idx = self._idx(env_idx)
        for meas in self.measures.values():
            meas.update(ctx, state, self, idx)

    @staticmethod
    def _info_type(meas: Measure) -> np.dtype:
        """What ``info`` reports a measure as: floats as float32 unless ``exact_info``, counts as int32."""
        dtype = meas.value.dtype
        if dtype.kind in "iu":
            return np.dtype(np.int32)
        return np.dtype(np.float32) if dtype.kind == "f" and not meas.exact_info else dtype

    def info(self, names: tuple[str, ...] | None = None) -> dict[str, torch.Tensor]:
        """Copies of the values as tensors on the device (see :meth:`_info_type`)."""
        types = self._info_dtype
        out = {name: torch.from_numpy(self[name].astype(types[name])) for name in names or self.names}
        if self.device.type != "cpu":
            out = {name: v.to(self.device) for name, v in out.items()}
        return out

    def state_dict(self) -> dict[str, dict[str, torch.Tensor]]:
        """Every measure's state as tensors (copies): what a replay needs to continue the episode."""
        return {
            name: {k: torch.tensor(getattr(meas, k), device=self.device) for k in meas.state_names}
            for name, meas in self.measures.items()
        }

    def load_state_dict(self, state: dict, env_idx: torch.Tensor | None = None) -> None:
        """Restore rows ``env_idx`` (all by default) from :meth:`state_dict` output."""
        idx = self._idx(env_idx)
        missing = sorted(set(self.measures) - set(state))
        if missing:
            raise KeyError(f"the task state has no measure {', '.join(missing)}")
        for name, meas in self.measures.items():
            for k in meas.state_names:
                saved = state[name][k]
                saved = saved.cpu().numpy() if isinstance(saved, torch.Tensor) else np.asarray(saved)
                getattr(meas, k)[idx] = saved[idx]
