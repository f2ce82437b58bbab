"""Sensor noise for camera observations: Gaussian RGB noise and a structured-light depth model.

Pure torch, NumPy and Numba (no simulator import), batched over sub-envs, on the device of the input images.

Two models, each built once per camera resolution (and seed):

* :class:`RGBNoise`: ``out = clip(round(rgb + 255 * sigma * z), 0, 255)`` on uint8 ``(N, H, W, 3)`` images,
  ``z ~ N(0, 1)`` i.i.d. per pixel and channel (Habitat's Gaussian RGB noise model convention: ``sigma`` is
  the standard deviation on the [0, 1] intensity scale; the PointNav 2020 challenge used 0.1).
* :class:`DepthNoise`: a Kinect-style structured-light model (the simulated-Kinect model of Handa et al.
  2014, with the disparity noise of Barron & Malik): pixel jitter, Gaussian noise on the disparity, disparity
  quantisation and a range limit. See its docstring for the formula.

Determinism. ``__call__(img, keys)`` takes one integer key per image (``keys``: ints, an int64 array or a
tensor of shape ``(N,)``); the noise of image ``i`` is a function of ``(seed, keys[i])`` only: the same key
gives the same noise whatever the batch, the device, the memory layout or the history of calls, and
different keys give different noise. The env derives the keys from ``(episode, step)`` (:func:`frame_keys`),
so a recorded episode replays exactly. The banks come from NumPy's PCG64, the same on every platform.

Speed. A fresh ``torch.randn`` of a 640x480x3 frame costs several milliseconds on a CPU core, more than the
whole noise budget. Both models therefore draw their standard-normal samples once, at construction, into a
*noise bank* of ``bank_frames`` (default 4, at least 4) frames' worth, already scaled and stored as the
per-frame arithmetic uses them, and a frame takes a window of the bank at an offset hashed from
``(seed, key)`` (SplitMix64):

* RGB: the int16 steps ``round(255 sigma z)`` (see :class:`RGBNoise`), windows at pixel granularity:
  ``(bank_frames - 1) * H * W + 1`` of them (0.9 M at 640x480);
* depth, disparity noise: float32, pixel-granular windows, as many;
* depth, pixel jitter: whole-pixel (row, column) shifts (border clamping baked into the column), windows at
  row granularity: ``(bank_frames - 1) * H + 1`` jitter patterns (1441 at 480 rows), drawn independently of
  the disparity window.

Two frames share noise structure only as shifted copies of the same bank; within a frame all samples are
distinct draws. No fresh random numbers per frame.

On the CPU each batch goes through one fused kernel per model (:mod:`biovln_ms.sensor_noise_kernels`,
compiled by Numba), which keeps the banks compact: RGB steps as int8 (RGBA layout, the rare steps beyond
+-127 listed apart), each pixel's shift as a one-byte code (two bytes beyond 7 rows of jitter); 11.1 MB at
640x480 with 4 bank frames. Both work in place when ``out`` is the input, as in the env. On other devices
the whole batch goes through torch kernels, the same arithmetic pass by pass (equal bit for bit; the tests
check it on CPU tensors), from banks laid out for them (three uint8 RGB banks, int32 read positions) and
with work buffers (2.5 MB per 640x480 int16 depth image, 3.7 MB for float): one instance must not be
called from two threads at once there. A 3-channel contiguous RGB input adds a 3.7 MB bank in that layout.
``benchmarks/sensor_noise.py`` gives the cost per frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

__all__ = ["DepthNoise", "RGBNoise", "frame_keys"]

_M64 = (1 << 64) - 1
# stream constants: the three noise terms draw independent banks and offsets from one (seed, key)
_RGB_STREAM = 0x52474221
_SHIFT_STREAM = 0x4A495454
_DISP_STREAM = 0x44495350


def _mix(x: int) -> int:
    """SplitMix64's finaliser on a Python int in ``[0, 2**64)``."""
    x = (x + 0x9E3779B97F4A7C15) & _M64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _M64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _M64
    return x ^ (x >> 31)


def _mix_np(x: np.ndarray) -> np.ndarray:
    """:func:`_mix` on a uint64 array (NumPy wraps modulo 2**64 silently)."""
    x = x + np.uint64(0x9E3779B97F4A7C15)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def _bank_seed(seed: int, stream: int) -> int:
    return _mix((seed ^ (stream << 32)) & _M64)


def _standard_normal(seed: int, stream: int, shape: tuple[int, ...]) -> torch.Tensor:
    """float32 N(0, 1) samples for a bank, from NumPy's PCG64 (the same on every platform and device)."""
    rng = np.random.Generator(np.random.PCG64(_bank_seed(seed, stream)))
    return torch.from_numpy(rng.standard_normal(shape, dtype=np.float32))


def _offsets(seed: int, stream: int, keys: list[int] | np.ndarray, n_offsets: int) -> list[int]:
    """Bank offset in ``[0, n_offsets)`` of each key: ``mix(key ^ mix(seed ^ stream << 32)) % n_offsets``."""
    s = _bank_seed(seed, stream)
    if len(keys) <= 64:  # Python ints beat NumPy's per-call overhead on a few keys
        return [_mix((int(k) & _M64) ^ s) % n_offsets for k in keys]
    h = _mix_np(np.asarray(keys, dtype=np.int64).view(np.uint64) ^ np.uint64(s))
    return (h % np.uint64(n_offsets)).astype(np.int64).tolist()


def frame_keys(episodes, steps) -> np.ndarray:
    """One int64 noise key per sub-env from its episode id and step: ``episode << 32 | step``.

    ``episodes`` and ``steps`` broadcast (ints or arrays). Collision-free for ``0 <= episode < 2**31`` and
    ``0 <= step < 2**32``; the models hash the key with their seed, so neighbouring keys give unrelated noise.
    """
    e, s = np.asarray(episodes), np.asarray(steps)
    few = max(e.size, s.size) <= 64 and e.ndim <= 1 and s.ndim <= 1
    if few and (e.size == s.size or 1 in (e.size, s.size)):  # Python ints: faster on a few envs
        ev, sv = e.reshape(-1).tolist(), s.reshape(-1).tolist()
        n = max(len(ev), len(sv))
        pairs = list(zip(ev * n if len(ev) == 1 else ev, sv * n if len(sv) == 1 else sv))
        if any(a >> 31 or b >> 32 for a, b in pairs):  # a bit above the range, or a negative number's sign
            raise ValueError("frame_keys needs 0 <= episode < 2**31 and 0 <= step < 2**32")
        return np.array([a << 32 | b for a, b in pairs], dtype=np.int64)
    e, s = e.astype(np.int64), s.astype(np.int64)
    if ((e >> 31) | (s >> 32)).any():
        raise ValueError("frame_keys needs 0 <= episode < 2**31 and 0 <= step < 2**32")
    return ((e << 32) | s).reshape(-1)


def _key_list(keys, n: int | None) -> list[int]:
    """``keys`` (an int, a sequence, an integer array or tensor) as ``n`` Python ints (any number if None)."""
    if isinstance(keys, np.ndarray) and keys.dtype == np.int64 and keys.ndim == 1:  # what frame_keys gives
        out = keys.tolist()
    elif isinstance(keys, (int, np.integer)) and not isinstance(keys, bool):
        out = [int(keys)]
    else:
        if isinstance(keys, torch.Tensor):
            keys = keys.detach().cpu().numpy()
        k = np.asarray(keys)
        if k.ndim > 1 or (k.size and not np.issubdtype(k.dtype, np.integer)):
            raise ValueError(f"keys must be integers, one per image in the batch; got {k.dtype} {k.shape}")
        out = k.reshape(-1).astype(np.int64).tolist()
    if n is not None and len(out) != n:
        raise ValueError(f"keys must be {n} integers (one per image in the batch), got {len(out)}")
    return out


def _check_image(img, height: int, width: int, channels: int, what: str) -> None:
    if not isinstance(img, torch.Tensor) or img.ndim != 4 or img.shape[1:] != (height, width, channels):
        shape = tuple(img.shape) if isinstance(img, torch.Tensor) else type(img).__name__
        raise ValueError(f"{what} expects a (N, {height}, {width}, {channels}) tensor, got {shape}")


def _check_out(out, img: torch.Tensor) -> torch.Tensor:
    if out is None:
        return torch.empty(img.shape, dtype=img.dtype, device=img.device)
    if not isinstance(out, torch.Tensor) or out.shape != img.shape or out.dtype != img.dtype:
        raise ValueError("out must be a tensor of the input's shape and dtype")
    if not out.is_contiguous() or out.device != img.device:
        raise ValueError("out must be contiguous and on the input's device")
    return out


def _windows(bank: torch.Tensor, size: int, offsets: list[int]) -> torch.Tensor:
    """``(n, size)``: row ``i`` is ``bank[offsets[i] : offsets[i] + size]``; a view for one offset (no copy),
    a gather from the bank's sliding windows (a strided view) for several."""
    if len(offsets) == 1:
        o = offsets[0]
        return bank[o : o + size].unsqueeze(0)
    win = torch.tensor(offsets, dtype=torch.int64, device=bank.device)
    return bank.unfold(0, size, 1)[win]


#: depth dtypes the kernel writes directly (its lookup table in that dtype); others go through lut indices
_KERNEL_DTYPES = (torch.int16, torch.int32, torch.int64, torch.float32, torch.float64)


def _kernels():
    """The fused CPU kernels (:mod:`biovln_ms.sensor_noise_kernels`), imported on first use: Numba's import
    costs a third of a second, which an env without image noise does not pay."""
    from biovln_ms import sensor_noise_kernels

    return sensor_noise_kernels


def _batched(img: torch.Tensor) -> bool:
    """CPU: the batch through a fused kernel (bank windows are slices); other devices: the whole batch in
    one set of torch kernels (gathered windows)."""
    return img.device.type != "cpu"


def _bank_frames_ok(bank_frames: int) -> None:
    if int(bank_frames) != bank_frames or bank_frames < 4:
        raise ValueError(f"bank_frames must be an integer >= 4, got {bank_frames}")


def _rgba_base(img: torch.Tensor) -> torch.Tensor | None:
    """The RGBA tensor under an ``(N, H, W, 3)`` view of it (ManiSkill's minimal shader hands out
    ``rgba[..., :3]``): ``(N, H, W, 4)`` with each image contiguous, or None if ``img`` is not such a view."""
    n, h, w, _ = img.shape
    s0 = img.stride(0)
    if img.stride()[1:] != (4 * w, 4, 1) or (n > 1 and s0 < h * w * 4):
        return None
    end = img.storage_offset() + (n - 1) * s0 + h * w * 4  # one past the last alpha byte
    if end > img.untyped_storage().nbytes() // img.element_size():
        return None
    return img.as_strided((n, h, w, 4), (s0, 4 * w, 4, 1))


def _kernel_bank(steps: torch.Tensor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The RGB kernel's bank of int16 ``steps``: int8 in two's complement (as uint8), saturated at +-127,
    and the positions (sorted) and values of the steps beyond."""
    wide = (steps.abs() > 127).nonzero().reshape(-1)
    n8 = steps.clamp(-127, 127).to(torch.int8).view(torch.uint8)
    return n8.numpy(), wide.numpy(), steps[wide].numpy()


@dataclass(eq=False)
class RGBNoise:
    """Gaussian noise on uint8 RGB images ``(N, H, W, 3)`` (ManiSkill's ``obs["sensor_data"][cam]["rgb"]``).

    ``out = clip(round(rgb + 255 * sigma * z), 0, 255)`` as uint8, with ``z ~ N(0, 1)`` i.i.d. per pixel and
    channel and ``sigma`` the standard deviation on the [0, 1] intensity scale (Habitat's Gaussian noise
    model; the PointNav 2020 challenge used ``sigma = 0.1``). As ``rgb`` is an integer,
    ``round(rgb + 255 sigma z) = rgb + round(255 sigma z)``: integer steps ``n``, clipped to +-255 (which
    saturate any pixel anyway, so no output changes). On the CPU one fused uint8 pass adds ``n`` with
    saturation (:func:`~biovln_ms.sensor_noise_kernels.rgb_frames`); elsewhere two torch passes with no
    temporary: ``clip(rgb + n, 0, 255) = clip(rgb, max(-n, 0), 255 - max(n, 0)) + n``, whose sum stays in
    [0, 255], so a clamp between two bound banks then a wrapping add of ``n mod 256`` (a third bank).

    ``__call__(rgb, keys)``: the noise of image ``i`` is a function of ``(seed, keys[i])`` only (module
    docstring), whatever the memory layout: a contiguous image and a 3-channel view of an RGBA image (what
    ManiSkill's minimal shader returns; the result is then such a view too, its alpha the input's) get the
    same noise. Other layouts are copied to a contiguous image first. ``sigma = 0`` returns the input.
    """

    height: int
    width: int
    sigma: float = 0.1
    seed: int = 0
    bank_frames: int = 4
    device: str | torch.device = "cpu"
    _banks: dict = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        if self.height < 1 or self.width < 1:
            raise ValueError(f"image size must be positive, got {self.height}x{self.width}")
        if not (self.sigma >= 0.0 and math.isfinite(self.sigma)):
            raise ValueError(f"sigma must be a finite number >= 0, got {self.sigma}")
        _bank_frames_ok(self.bank_frames)
        self.frame_pixels = self.height * self.width
        self.n_offsets = (self.bank_frames - 1) * self.frame_pixels + 1  # pixel-granular windows
        if self.sigma > 0:
            z = _standard_normal(int(self.seed), _RGB_STREAM, (self.bank_frames * self.frame_pixels, 4))
            steps = z.mul_(255.0 * self.sigma).round_().clamp_(-255, 255).to(torch.int16)
            steps[:, 3] = 0  # alpha passes through
            self._banks[("numpy", 4)] = _kernel_bank(steps.reshape(-1))
            if torch.device(self.device).type != "cpu":
                self._bank(torch.device(self.device), 4)

    def _steps(self, channels: int) -> torch.Tensor:
        """The int16 steps ``n`` laid out as RGBA (4) or RGB (3) pixels: the same samples, pixel for pixel
        (rebuilt from the kernel's RGBA bank, the one kept)."""
        n8, wide, wide_steps = self._banks[("numpy", 4)]
        steps = torch.from_numpy(n8).view(torch.int8).to(torch.int16)
        steps[torch.from_numpy(wide)] = torch.from_numpy(wide_steps)
        return steps if channels == 4 else steps.view(-1, 4)[:, :3].reshape(-1)

    def _bank(self, device: torch.device, channels: int) -> torch.Tensor:
        """The torch path's ``(3, bytes)`` uint8 banks: ``clip(x + n, 0, 255) = clip(x, max(-n, 0), 255 -
        max(n, 0)) + n``, the sum never leaving [0, 255], so a clamp between two bounds (lower, upper), then a
        wrapping add of ``n mod 256`` (step)."""
        bank = self._banks.get((device, channels))
        if bank is None:
            steps = self._steps(channels)
            lo, hi = (-steps).clamp_(min=0), 255 - steps.clamp(min=0)
            bank = torch.stack((lo, hi, steps.remainder(256))).to(torch.uint8).to(device)
            self._banks[(device, channels)] = bank
        return bank

    def _numpy_banks(self, channels: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The CPU kernel's bank (made once): ``n`` as int8 in two's complement (uint8 bytes), saturated at
        +-127, and the positions (sorted) and values of the rare steps beyond (``|n| > 127`` is a 5-sigma
        draw at ``sigma = 0.1``): a third of the three banks' bytes, so a third of the memory traffic."""
        banks = self._banks.get(("numpy", channels))
        if banks is None:
            banks = self._banks[("numpy", channels)] = _kernel_bank(self._steps(channels))
        return banks

    def offsets(self, keys) -> list[int]:
        """The bank offset of each key, in pixels (what selects a frame's noise)."""
        return _offsets(int(self.seed), _RGB_STREAM, _key_list(keys, None), self.n_offsets)

    def __call__(self, rgb: torch.Tensor, keys, out: torch.Tensor | None = None) -> torch.Tensor:
        """Noisy copy of ``rgb`` (uint8 ``(N, H, W, 3)``), one key per image, in the input's layout.
        ``out`` (optional) receives the result and may be ``rgb`` itself; it must be laid out as ``rgb``
        (contiguous, or a view of a contiguous RGBA tensor)."""
        _check_image(rgb, self.height, self.width, 3, "RGBNoise")
        if rgb.dtype != torch.uint8:
            raise ValueError(f"RGBNoise expects uint8 images, got {rgb.dtype}")
        n = rgb.shape[0]
        keys = _key_list(keys, n)
        if self.sigma == 0:
            return rgb if out is None else _check_out(out, rgb).copy_(rgb)
        src = rgb if rgb.is_contiguous() else _rgba_base(rgb)
        if src is None:  # another layout: the slow copy once, then the contiguous path
            src = rgb = rgb.contiguous()
        channels = src.shape[3]
        if out is None:
            dst = torch.empty(src.shape, dtype=torch.uint8, device=rgb.device)
            out = dst if channels == 3 else dst[..., :3]
        elif out is rgb:
            dst = src
        else:
            if not isinstance(out, torch.Tensor) or out.shape != rgb.shape or out.dtype != torch.uint8:
                raise ValueError("out must be a uint8 tensor of the input's shape")
            dst = out if channels == 3 else _rgba_base(out)
            if out.device != rgb.device or dst is None or not dst.is_contiguous():
                raise ValueError(
                    "out must be laid out as the input (contiguous, or an RGBA view), on its device"
                )
        if n == 0:
            return out
        size = self.frame_pixels * channels
        offs = [o * channels for o in _offsets(int(self.seed), _RGB_STREAM, keys, self.n_offsets)]
        if _batched(rgb):
            lo, hi, step = self._bank(rgb.device, channels)
            windows = [_windows(b, size, offs).view(src.shape) for b in (lo, hi, step)]
            torch.clamp(src, min=windows[0], max=windows[1], out=dst).add_(windows[2])
        else:
            if dst is not src:
                dst.copy_(src)  # the kernel works in place
            images = dst.as_strided((n, size), (dst.stride(0), 1)).numpy()  # each image contiguous
            bank, wide, wide_steps = self._numpy_banks(channels)
            _kernels().rgb_frames(images, bank, wide, wide_steps, np.asarray(offs, dtype=np.int64))
        return out


@dataclass(eq=False)
class DepthNoise:
    """Structured-light (Kinect-style) depth noise: the simulated-Kinect model of Handa et al. 2014 with
    Barron & Malik's disparity noise.

    Input: depth images ``(N, H, W, 1)``, integer millimetres (what ManiSkill's rgbd obs mode returns in
    ``obs["sensor_data"][cam]["depth"]``: int16 mm, 0 where no surface was hit) or floating-point metres.
    The output has the input's dtype and units; 0 means "no reading" in both.

    For each pixel ``(u, v)``, with ``f`` the focal length in pixels (``focal_px``: ``fx``, entry ``[0, 0]``
    of ManiSkill's ``intrinsic_cv``) and ``b`` the projector-camera baseline (``baseline_m``):

    1. pixel jitter: ``z = depth[v + round(sigma_shift * n_v), u + round(sigma_shift * n_u)]``, the shifts
       clipped to ``+-ceil(5 sigma_shift)`` px and the coordinates clamped at the image borders;
    2. disparity ``d = f b / z``, with Gaussian noise and quantised to ``disparity_step``:
       ``d' = disparity_step * round((d + sigma_disparity * n_d) / disparity_step)``;
    3. ``z' = f b / d'``, and ``z' = 0`` (no reading, as a real sensor reports) where ``d' <= 0`` or ``z'``
       is outside ``[min_depth, max_depth]``; input pixels at 0 (no hit) stay 0.

    ``n_u, n_v, n_d ~ N(0, 1)`` i.i.d. per pixel. The depth error has std about
    ``z**2 * sigma_disparity / (f b)`` (quadratic in depth) and the output takes only the discrete values
    ``f b / (k disparity_step)``, ``k = 1, 2, ...``. Defaults: ``b = 0.075 m``, ``sigma_shift = 0.5 px``,
    ``sigma_disparity = 1/6 px``, ``disparity_step = 1/8 px``, range ``[0.3 m, 10 m]``.

    Computed as ``k = trunc(clip(f b / (disparity_step z) + n_d sigma_disparity / disparity_step + 1/2,
    0, k_max))`` (the bank holds the shifted, scaled ``n_d``) and ``z' = lut[k]`` (:meth:`depth_lut`).
    ``__call__(depth, keys)``: the noise of image ``i`` is a function of ``(seed, keys[i])`` only. The
    jitter bank holds each pixel's whole-pixel (row, column) shift (the column clamp baked in), and a
    frame's jitter window starts at a whole bank row: ``(bank_frames - 1) * H + 1`` jitter patterns,
    combined with ``(bank_frames - 1) * H * W + 1`` independently chosen disparity-noise windows. Depths are
    read as int16 millimetres or float32 (other dtypes are converted first).
    """

    height: int
    width: int
    focal_px: float
    baseline_m: float = 0.075
    sigma_shift_px: float = 0.5
    sigma_disparity_px: float = 1.0 / 6.0
    disparity_step_px: float = 1.0 / 8.0
    min_depth_m: float = 0.3
    max_depth_m: float = 10.0
    seed: int = 0
    bank_frames: int = 4
    device: str | torch.device = "cpu"
    _banks: dict = field(init=False, repr=False, default_factory=dict)
    _luts: dict = field(init=False, repr=False, default_factory=dict)
    _kernel_args: dict = field(init=False, repr=False, default_factory=dict)  # dtype -> _kernel_args_of
    _plans: dict = field(init=False, repr=False, default_factory=dict)
    # the CPU kernel's banks (made in __post_init__): shift codes, their (dy, dx, dy W + dx), disparity noise
    _shift_codes: np.ndarray = field(init=False, repr=False)
    _shift_table: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False, repr=False)
    _disp: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.height < 1 or self.width < 1:
            raise ValueError(f"image size must be positive, got {self.height}x{self.width}")
        for name in ("focal_px", "baseline_m", "disparity_step_px", "min_depth_m"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number > 0, got {v}")
        for name in ("sigma_shift_px", "sigma_disparity_px"):
            v = getattr(self, name)
            if not (v >= 0 and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number >= 0, got {v}")
        if not (self.max_depth_m > self.min_depth_m and math.isfinite(self.max_depth_m)):
            raise ValueError(f"max_depth_m ({self.max_depth_m}) must be finite and exceed min_depth_m")
        _bank_frames_ok(self.bank_frames)
        H, W, B = self.height, self.width, self.bank_frames
        self.frame_size = H * W
        self.n_offsets = (B - 1) * H * W + 1  # disparity-noise windows (element-granular)
        self.n_row_offsets = (B - 1) * H + 1  # jitter windows (row-granular)
        self.pad = int(math.ceil(5.0 * self.sigma_shift_px))  # rows replicated above and below
        if (B * H + 2 * self.pad) * W >= 1 << 31:
            raise ValueError(f"a {H}x{W} image with {B} bank frames is too large for int32 indices")
        self.q_scale = self.focal_px * self.baseline_m / self.disparity_step_px  # k = q_scale / z, z in m
        # k above k_max means nearer than min_depth; lut[k_max] = 0 also catches z = 0 (k = inf)
        self.k_max = int(math.floor(self.q_scale / self.min_depth_m)) + 1
        if self.k_max >= 1 << 24:
            raise ValueError("focal_px * baseline_m / (disparity_step_px * min_depth_m) must be < 2**24")
        seed = int(self.seed)
        p = self.pad
        if p > 127:
            shift = self.sigma_shift_px
            raise ValueError(f"sigma_shift_px must be <= 25.4 (shifts up to 127 px), got {shift:g}")
        # the shift of bank pixel (Y, x): it reads row Y + dy, column x + dx (dx keeps it in the image), as a
        # code (dy + p) (2p + 1) + dx + p: one byte per pixel up to p = 7 (sigma_shift_px 1.4), else two
        dy, dx = _standard_normal(seed, _SHIFT_STREAM, (2, B * H, W)).mul_(self.sigma_shift_px)
        dy, dx = dy.round_().clamp_(-p, p), dx.round_().clamp_(-p, p)
        dx = (torch.arange(W).reshape(1, -1) + dx).clamp_(0, W - 1) - torch.arange(W)
        side = 2 * p + 1
        codes = ((dy + p) * side + dx + p).to(torch.int32).reshape(-1).numpy()
        self._shift_codes = codes.astype(np.uint8 if side * side <= 256 else np.uint16)
        dys, dxs = np.divmod(np.arange(side * side, dtype=np.int32), side)
        self._shift_table = (dys - p, dxs - p, (dys - p) * W + dxs - p)  # dy, dx and dy W + dx of each code
        disp = _standard_normal(seed, _DISP_STREAM, (B * H * W,))
        self._banks["disp"] = disp.mul_(self.sigma_disparity_px / self.disparity_step_px).add_(0.5)
        self._disp = self._banks["disp"].numpy()  # the CPU kernel's view
        if torch.device(self.device).type != "cpu":
            self._banks_on(torch.device(self.device))

    def _banks_on(self, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
        """The torch path's banks on ``device``: jitter as int32 read positions into a stack of bank images
        with ``pad`` replicated rows above and below (``(Y + pad + dy) W + x + dx``), and the disparity
        noise."""
        banks = self._banks.get(device)
        if banks is None:
            W, p = self.width, self.pad
            dys, dxs, _ = self._shift_table  # each code's (dy, dx)
            dy, dx = (torch.from_numpy(t[self._shift_codes]).reshape(-1, W) for t in (dys, dxs))
            rows = torch.arange(dy.shape[0]).reshape(-1, 1) + p + dy
            jitter = (rows * W + torch.arange(W) + dx).reshape(-1) if p else dy[:0, 0]
            banks = self._banks[device] = (jitter.to(device), self._banks["disp"].to(device))
        return banks

    def depth_lut(self, dtype: torch.dtype, device: torch.device | str = "cpu") -> torch.Tensor:
        """``lut[k]``, ``k`` in ``[0, k_max]``: the measured depth at disparity ``k * disparity_step_px``,
        ``f b / (k disparity_step)`` in mm (rounded) for integer dtypes and metres for floating ones, and 0
        where that is outside ``[min_depth_m, max_depth_m]`` (``k = 0`` and ``k = k_max`` included)."""
        key = (dtype, torch.device(device))
        lut = self._luts.get(key)
        if lut is None:
            k = np.arange(self.k_max + 1, dtype=np.float64)
            with np.errstate(divide="ignore"):
                z = self.q_scale / k  # metres, inf at k = 0
            valid = (z >= self.min_depth_m) & (z <= self.max_depth_m)
            valid[-1] = False
            if dtype.is_floating_point:
                table = np.where(valid, z, 0.0)
            else:
                table = np.where(valid, np.round(z * 1000.0), 0.0)
                if table.max() > torch.iinfo(dtype).max:
                    raise ValueError(f"max_depth_m = {self.max_depth_m} m overflows {dtype} millimetres")
            lut = self._luts[key] = torch.as_tensor(table).to(dtype=dtype, device=key[1])
        return lut

    def offsets(self, keys) -> tuple[list[int], list[int]]:
        """``(jitter bank rows, disparity-noise offsets)`` of each key: where its two windows start."""
        return self._windows_of(_key_list(keys, None))

    def _windows_of(self, keys: list[int]) -> tuple[list[int], list[int]]:
        seed = int(self.seed)
        rows = _offsets(seed, _SHIFT_STREAM, keys, self.n_row_offsets)
        return rows, _offsets(seed, _DISP_STREAM, keys, self.n_offsets)

    def __call__(self, depth: torch.Tensor, keys, out: torch.Tensor | None = None) -> torch.Tensor:
        """Noisy copy of ``depth`` (``(N, H, W, 1)``, integer mm or floating m), one key per image. ``out``
        (optional, contiguous) receives the result and may be ``depth`` itself."""
        _check_image(depth, self.height, self.width, 1, "DepthNoise")
        if depth.dtype == torch.bool or depth.dtype.is_complex or depth.dtype == torch.uint8:
            raise ValueError(f"DepthNoise expects integer millimetres or floating metres, got {depth.dtype}")
        n = depth.shape[0]
        keys = _key_list(keys, n)
        out = _check_out(out, depth)
        if n == 0:
            return out
        rows, offs = self._windows_of(keys)
        if _batched(depth):
            jitter, disp = self._banks_on(depth.device)
            lut = self.depth_lut(depth.dtype, depth.device)
            self._batch(depth, jitter, rows, _windows(disp, self.frame_size, offs), lut, out)
        else:
            self._frames(depth, rows, offs, out)
        return out

    def _frames(self, depth, rows, offs, out) -> None:
        """The CPU path: the batch in one fused kernel (:func:`~biovln_ms.sensor_noise_kernels.depth_frames`).
        Integer millimetres other than int16 and floating metres other than float32 are read as float32,
        as the torch path reads them; a result dtype NumPy lacks goes through lut indices."""
        q, lookup, direct = self._kernel_args.get(depth.dtype) or self._kernel_args_of(depth.dtype)
        z = depth if depth.dtype in (torch.int16, torch.float32) else depth.to(torch.float32)
        z = z.contiguous()  # the kernel reads whole rows; out may still be this tensor (its ring of rows)
        dst = out if direct else torch.empty(out.shape, dtype=torch.int32)
        n, H, W = depth.shape[0], self.height, self.width
        _kernels().depth_frames(
            z.view(n, H * W).numpy(),
            self._shift_codes,
            *self._shift_table,
            np.asarray(rows, dtype=np.int64),
            self.pad,
            self._disp,
            np.asarray(offs, dtype=np.int64),
            q,
            self.k_max,
            *lookup,
            dst.view(n, H, W).numpy(),
        )
        if not direct:
            torch.index_select(self.depth_lut(depth.dtype), 0, dst.view(-1), out=out.view(-1))

    def _kernel_args_of(self, dtype: torch.dtype) -> tuple[np.float32, tuple, bool]:
        """The depth kernel's per-dtype arguments (made once per dtype): ``q`` (``k = q / z``, z in m or mm),
        the lookup (``lut`` and the arithmetic form, :meth:`_arithmetic_lut`) and whether the kernel writes
        the result directly (``dtype`` in ``_KERNEL_DTYPES``) or lut indices."""
        q = np.float32(self.q_scale if dtype.is_floating_point else self.q_scale * 1000.0)
        if dtype in _KERNEL_DTYPES:
            lookup = (self.depth_lut(dtype).numpy(), *self._arithmetic_lut(dtype))
        else:
            lookup = (np.arange(self.k_max + 1, dtype=np.int32), 0, 0, np.float32(0.0))
        args = self._kernel_args[dtype] = (q, lookup, dtype in _KERNEL_DTYPES)
        return args

    def _arithmetic_lut(self, dtype: torch.dtype) -> tuple[int, int, np.float32]:
        """``(near, far, mm)``: ``depth_lut(dtype)[k] = rint(mm / k)`` for ``near <= k <= far`` and 0
        elsewhere, computed in float32, if that holds at every ``k`` (the kernel then computes instead of
        looking up; it holds for int16 millimetres), else ``(0, 0, 0)``. Made once per dtype, through
        :meth:`_kernel_args_of`."""
        lut = self.depth_lut(dtype).numpy() if dtype in (torch.int16, torch.int32) else None
        nonzero = np.flatnonzero(lut) if lut is not None else []
        if len(nonzero) and nonzero[-1] - nonzero[0] + 1 == len(nonzero):
            near, far, mm = int(nonzero[0]), int(nonzero[-1]), np.float32(self.q_scale * 1000.0)
            k = np.arange(self.k_max + 1, dtype=np.float32)
            with np.errstate(divide="ignore"):
                formula = np.where((k >= near) & (k <= far), np.rint(mm / k), 0.0).astype(lut.dtype)
            if np.array_equal(formula, lut):
                return near, far, mm
        return 0, 0, np.float32(0.0)

    def _plan(self, device: torch.device, n: int, dtype: torch.dtype) -> dict:
        """Work buffers of the batched path for ``n`` images, per ``dtype`` of the depth copy (int16 mm stays
        int16, anything else float32): one image each with ``pad`` replicated rows above and below."""
        plan = self._plans.get((device, n, dtype))
        if plan is None:
            H, W, p = self.height, self.width, self.pad
            if n * (H + 2 * p) * W >= 1 << 31:
                raise ValueError(f"a batch of {n} {H}x{W} depth images is too large for int32 indices")
            v = torch.empty(n * H * W, dtype=torch.float32, device=device)  # disparity, in steps
            plan = self._plans[(device, n, dtype)] = {
                "stack": torch.empty((n, H + 2 * p, W), dtype=dtype, device=device) if p else None,
                "z": torch.empty(n * H * W, dtype=dtype, device=device) if p else None,  # jittered depth
                "v": v,
                "q": v.view(torch.int32),  # the lut index, converted in place
                True: torch.tensor(self.q_scale, dtype=torch.float32, device=device),  # z in metres
                False: torch.tensor(self.q_scale * 1000.0, dtype=torch.float32, device=device),  # mm
            }
        return plan

    def _batch(self, depth, jitter, rows, noise, lut, out) -> None:
        """The whole batch in one set of kernels (other devices than the CPU): the reads and arithmetic of
        :meth:`_frames`, pass by pass."""
        n = depth.shape[0]
        H, W, p = self.height, self.width, self.pad
        dtype = torch.int16 if depth.dtype == torch.int16 else torch.float32
        plan = self._plan(depth.device, n, dtype)
        if p:
            img = plan["stack"]
            img[:, p : p + H].copy_(depth[..., 0])
            img[:, :p].copy_(img[:, p : p + 1].expand(n, p, W))  # replicated rows: reads past the edge clamp
            img[:, p + H :].copy_(img[:, p + H - 1 : p + H].expand(n, p, W))
            shift = [i * (H + 2 * p) * W - r * W for i, r in enumerate(rows)]  # bank row r -> image i
            idx = _windows(jitter, H * W, [r * W for r in rows])
            idx = idx + torch.tensor(shift, dtype=torch.int32, device=depth.device).unsqueeze(1)
            z = torch.index_select(img.view(-1), 0, idx.view(-1), out=plan["z"])
            noise = noise.reshape(-1)
        else:
            z, noise = depth[..., 0].to(dtype), noise.view(n, H, W)
        floating, v = depth.dtype.is_floating_point, plan["v"]
        # k = q_scale / z + the bank's noise (+ 1/2): inf at z = 0 (no hit), negative for z < 0, both
        # land on lut entries holding 0
        torch.addcdiv(noise, plan[floating], z, out=v.view(noise.shape))
        if floating:  # a NaN depth reads as "no reading"
            torch.nan_to_num_(v, nan=0.0)
        v.clamp_(0, self.k_max)
        q = plan["q"]
        q.copy_(v)  # float -> int32 in place; truncation = floor for v >= 0, the bank's + 1/2 rounds
        torch.index_select(lut, 0, q, out=out.view(-1))
