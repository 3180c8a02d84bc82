"""Fitting Gaussian splats to an image: initialisation, the training loop, densification.

One step renders the image (or a mini-batch of 16x16 tiles), computes the loss
and dL/dI on the host, back-propagates with the backward kernel and moves the
learned parameter groups with the optimiser.  Learning rates decay
exponentially to `lr_final` of their start over the run (by steps, or by the
time budget when one is set, whichever is further along).  Every
`densify_every` steps, until `densify_until` of the run, splats that
contribute nothing are pruned and the freed budget (up to `max_splats`) goes
to the splats with the largest mean position gradient: large ones are split
in two along their major axis, small ones cloned half a sigma away.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from ..errors import UsageError, require
from ..progress import progress
from . import INITS
from .gauss import BLENDS, MIN_LOG_SCALE, TILE, GaussParams, GaussRenderer
from .losses import LOSSES, loss_and_grad, psnr
from .optim import OPTIMIZERS, Optimizer
from .pixels import check_pixels

LEARN = ("scale-lum", "all")
LEARN_ALIASES = {"seed": "scale-lum"}  # old spellings, still accepted (FitConfig and --learn turn them into the new)
MAX_LR = 1000.0  # --lr multiplier; far above any useful rate, below where float32 steps overflow
LEARN_GROUPS = {"scale-lum": ("log_scale", "lum"), "all": ("xy", "log_scale", "theta", "color", "opacity")}
# Adam step sizes per group (in the group's own units: pixels, log-sigma, radians, colour values)
ADAM_LR = {"xy": 0.4, "log_scale": 0.04, "theta": 0.06, "color": 0.02, "lum": 0.02, "opacity": 0.04}
# SGD/momentum rates per group, multiplied by 3 N (N splats): a mean loss's gradient for one
# splat shrinks like its footprint over the image's H * W * 3 values, about 1 / (3 N)
SGD_LR = {"xy": 3.0, "log_scale": 0.15, "theta": 0.15, "color": 0.3, "lum": 0.3, "opacity": 0.3}


@dataclass(frozen=True)
class FitConfig:
    """Settings of one fit, each with its default; change one with dataclasses.replace."""

    splats: int = 5000  # initial number of splats
    epochs: int | None = None  # passes over the image; None: 1000, or until the time budget
    init: str = "gradient"  # uniform | random | gradient (more splats where the image has detail)
    learn: str = "all"  # scale-lum: log-scales and a per-splat luminance factor only ("seed" is its old name); all: every parameter
    blend: str = "normalized"  # sum | normalized
    optimizer: str = "adam"  # sgd | momentum | adam
    lr: float = 1.0  # multiplier of every group's default learning rate
    lr_final: float = 0.2  # learning rates decay to this fraction by the end of the run
    loss: str = "l2"  # l2 | l1 | l1-ssim
    seed: int = 0
    time_budget: float | None = None  # seconds of fitting; stops early when reached
    max_splats: int | None = None  # densification keeps N <= this (default: splats)
    batch: int = 0  # pixels per step, rounded to whole 16x16 tiles; 0: the full image
    densify_every: int = 100  # steps between densification rounds; 0 turns it off
    densify_until: float = 0.6  # fraction of the run after which N stays fixed
    log_every: int = 10  # steps between full-image PSNR measurements in the log

    def __post_init__(self):
        if isinstance(self.learn, str) and self.learn in LEARN_ALIASES:  # an old spelling: the same setting
            object.__setattr__(self, "learn", LEARN_ALIASES[self.learn])

    def validate(self, width: int, height: int) -> None:
        """UsageError naming the first setting that is out of range for a width x height target."""
        require(self.splats >= 1, f"--splats {self.splats} must be >= 1")
        require(self.epochs is None or self.epochs >= 0, f"--epochs {self.epochs} must be >= 0")
        require(self.init in INITS, f"--init {self.init!r} is unknown; allowed: {', '.join(INITS)}")
        require(self.learn in LEARN, f"--learn {self.learn!r} is unknown; allowed: {', '.join(LEARN)}")
        require(self.blend in BLENDS, f"--blend {self.blend!r} is unknown; allowed: {', '.join(BLENDS)}")
        require(self.optimizer in OPTIMIZERS, f"--optimizer {self.optimizer!r} is unknown; allowed: {', '.join(OPTIMIZERS)}")
        require(self.loss in LOSSES, f"--loss {self.loss!r} is unknown; allowed: {', '.join(LOSSES)}")
        require(math.isfinite(self.lr) and 0 < self.lr <= MAX_LR, f"--lr {self.lr} must be a number > 0 and <= {MAX_LR:g}")
        require(0 <= self.seed < 2**32, f"--seed {self.seed} must be from 0 to 2**32-1")
        require(self.time_budget is None or self.time_budget > 0, f"--time-budget {self.time_budget} must be > 0")
        require(self.batch >= 0, f"--batch {self.batch} must be >= 0 (0 = the full image)")
        require(self.max_splats is None or self.max_splats >= self.splats, f"--max-splats {self.max_splats} must be >= --splats {self.splats}")
        require(self.splats <= width * height * 4, f"--splats {self.splats} is more than 4 per pixel of the {width}x{height} image")


@dataclass
class FitResult:
    params: GaussParams
    image: np.ndarray  # final full render
    psnr: float
    steps: int
    seconds: float
    log: list[dict] = field(default_factory=list)  # step, epoch, seconds, splats, loss, psnr

    def _repr_png_(self) -> bytes:
        """The fitted image inline in Jupyter (the target's stored values, as written to files)."""
        from ..image.display import png_bytes

        return png_bytes(self.image, linear=False)


def as_rgb(pixels: np.ndarray) -> np.ndarray:
    """Float32 RGB (H, W, 3) from grey, grey+alpha, RGB or RGBA pixels."""
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    c = pixels.shape[2]
    if c in (1, 2):
        return np.ascontiguousarray(np.repeat(pixels[..., :1], 3, axis=2), np.float32)
    return np.ascontiguousarray(pixels[..., :3], np.float32)


# ----------------------------------------------------------------------------- initialisation


def initial_params(target: np.ndarray, n: int, init: str, blend: str, rng: np.random.Generator, renderer: GaussRenderer | None = None) -> GaussParams:
    """n isotropic splats, sized by their local spacing, coloured from the target at their centres."""
    h, w = target.shape[:2]
    if init == "uniform":
        cols = max(1, int(round(np.sqrt(n * w / h))))
        rows = -(-n // cols)
        i = np.arange(n)
        xy = np.stack([(i % cols + 0.5) * w / cols, (i // cols + 0.5) * h / rows], axis=1)
        density = np.full(n, n / (w * h))
    elif init == "random":
        xy = rng.random((n, 2)) * [w, h]
        density = np.full(n, n / (w * h))
    elif init == "gradient":
        grey = cv2.cvtColor(target, cv2.COLOR_RGB2GRAY)
        mag = np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0), cv2.Sobel(grey, cv2.CV_32F, 0, 1))
        mag = cv2.GaussianBlur(mag, (0, 0), 2.0).astype(np.float64)
        p = mag + 0.5 * mag.mean() + 1e-12  # detail attracts splats, flat areas keep some
        p = p.ravel() / p.sum()
        pick = rng.choice(w * h, size=n, replace=n > w * h, p=p)
        xy = np.stack([pick % w, pick // w], axis=1) + rng.random((n, 2))
        density = n * p[pick]  # splats per pixel around each one
    else:
        raise UsageError(f"--init {init!r} is unknown; allowed: {', '.join(INITS)}")
    sigma = np.clip(0.6 / np.sqrt(density), np.exp(MIN_LOG_SCALE), max(w, h) / 4)
    px = np.clip(xy.astype(int), 0, [w - 1, h - 1])
    color = target[px[:, 1], px[:, 0]]
    params = GaussParams(
        xy=xy,
        log_scale=np.log(np.stack([sigma, sigma], axis=1)),
        theta=np.zeros(n),
        color=color,
        lum=np.ones(n),
        opacity=np.ones(n),
        width=w,
        height=h,
        blend=blend,
    )
    if blend == "sum" and renderer is not None:
        # overlapping splats add up: divide each colour by the total weight at its centre
        white = params.copy()
        white.color[:] = 1.0
        weight = renderer.forward(white).weight
        params.color /= np.maximum(weight[px[:, 1], px[:, 0]], 1.0)[:, None]
    return params


# ----------------------------------------------------------------------------- densification


def densify(params: GaussParams, grad_norm: np.ndarray, weight: np.ndarray, max_splats: int, rng: np.random.Generator):
    """Prune non-contributors, then split/clone the splats with the largest position gradients.

    Returns (new params, src) where row i of the new params came from row src[i].
    """
    sigma_max = np.exp(params.log_scale.max(axis=1))
    dead = (params.opacity < 0.01) | (weight < 0.05)
    keep = np.nonzero(~dead)[0]
    free = max_splats - len(keep)
    candidates = keep[np.argsort(-grad_norm[keep], kind="stable")]
    candidates = candidates[grad_norm[candidates] > 0][: max(free, 0)]
    big = sigma_max[candidates] > np.median(sigma_max[keep]) if len(keep) else np.zeros(0, bool)
    src = np.concatenate([keep, candidates]).astype(np.int64)
    new = params.select(src)
    k = len(keep)
    split_rows = k + np.nonzero(big)[0]  # the added copy of a big splat
    split_parents = np.searchsorted(keep, candidates[big])  # its original, now at this row
    # split: both halves smaller, half a sigma either side along the major axis
    major = np.argmax(new.log_scale[split_rows], axis=1)
    ang = new.theta[split_rows] + np.where(major == 1, np.pi / 2, 0.0)
    step = 0.5 * np.exp(new.log_scale[split_rows].max(axis=1))
    offset = np.stack([np.cos(ang), np.sin(ang)], axis=1) * step[:, None]
    new.xy[split_rows] += offset
    new.xy[split_parents] -= offset
    new.log_scale[split_rows] -= np.log(1.6)
    new.log_scale[split_parents] -= np.log(1.6)
    # clone: the copy moves half its smaller sigma in a random (seeded) direction
    clone_rows = k + np.nonzero(~big)[0]
    direction = rng.normal(size=(len(clone_rows), 2))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True) + 1e-12
    new.xy[clone_rows] += direction * 0.5 * np.exp(new.log_scale[clone_rows].min(axis=1))[:, None]
    new.xy[:] = np.clip(new.xy, 0.0, [params.width, params.height])
    return new, src


# ----------------------------------------------------------------------------- training


class Fitter:
    """Fits GaussParams to `target` (H, W, 3 float32 in [0, 1]) with the settings of `config`."""

    def __init__(self, device, target: np.ndarray, config: FitConfig):
        self.target = as_rgb(target)
        check_pixels(self.target, "the target image")
        h, w = self.target.shape[:2]
        config.validate(w, h)
        self.config, self.width, self.height = config, w, h
        self.rng = np.random.default_rng(config.seed)
        self.renderer = GaussRenderer(device, w, h, config.blend, fit_loss=config.loss)  # refuses what memory cannot hold
        self.groups = LEARN_GROUPS[config.learn]
        base = (
            ADAM_LR
            if config.optimizer == "adam"
            else {k: v * 3 * config.splats * (0.1 if config.optimizer == "momentum" else 1.0) for k, v in SGD_LR.items()}
        )
        self.base_lr = {k: base[k] * config.lr for k in self.groups}
        self.max_splats = config.max_splats or config.splats
        self.tiles_per_step = (
            len(self.renderer.all_tiles) if config.batch == 0 else min(len(self.renderer.all_tiles), max(1, round(config.batch / (TILE * TILE))))
        )
        self.steps_per_epoch = -(-len(self.renderer.all_tiles) // self.tiles_per_step)

    def pixel_mask(self, tiles: np.ndarray) -> np.ndarray:
        r = self.renderer
        grid = np.zeros(r.tiles_x * r.tiles_y, bool)
        grid[tiles] = True
        grid = grid.reshape(r.tiles_y, r.tiles_x)
        return np.repeat(np.repeat(grid, TILE, 0), TILE, 1)[: self.height, : self.width]

    def run(self, params: GaussParams | None = None, *, show_progress: bool = True) -> FitResult:
        cfg, r = self.config, self.renderer
        if params is None:
            params = initial_params(self.target, cfg.splats, cfg.init, cfg.blend, self.rng, r)
        epochs = cfg.epochs if cfg.epochs is not None else (10**9 if cfg.time_budget else 1000)
        total_steps = epochs * self.steps_per_epoch
        opt = Optimizer(cfg.optimizer, self.base_lr)
        grad_sum = np.zeros(params.n)
        weight_sum = np.zeros(params.n)
        seen = 0
        log = []
        start = time.perf_counter()
        bar = None
        if show_progress:
            bar = progress(total=None if cfg.time_budget and cfg.epochs is None else total_steps, desc="splat gauss", unit="step")
        step = 0
        order = np.zeros(0, np.int32)
        while step < total_steps:
            elapsed = time.perf_counter() - start
            if cfg.time_budget and elapsed >= cfg.time_budget:
                break
            done = max(step / total_steps, elapsed / cfg.time_budget if cfg.time_budget else 0.0)
            for k in self.groups:
                opt.lrs[k] = self.base_lr[k] * cfg.lr_final**done
            tiles, mask, order = self._next_tiles(order)
            frame = r.forward(params, tiles)
            image = frame.image if mask is None else np.where(mask[..., None], frame.image, self.target)
            loss, d_image = loss_and_grad(cfg.loss, image, self.target, mask)
            grads = r.backward(frame, d_image)
            opt.step(params.groups(), grads)
            self._project(params)
            grad_sum += np.linalg.norm(grads["xy"], axis=1)
            weight_sum += grads["weight"]
            seen += 1
            step += 1
            if step % cfg.log_every == 0 or step == 1:
                self._log_step(log, bar, params, step, start, loss, image, mask)
            if bar is not None:
                bar.update(1)
            if cfg.densify_every and step % cfg.densify_every == 0 and done < cfg.densify_until and "xy" in self.groups:
                params, src = densify(params, grad_sum / seen, weight_sum / seen * self.steps_per_epoch, self.max_splats, self.rng)
                opt.reindex(src)
                grad_sum, weight_sum, seen = np.zeros(params.n), np.zeros(params.n), 0
        if bar is not None:
            bar.close()
        return self._finish(params, step, start, log)

    def _next_tiles(self, order: np.ndarray):
        """The mini-batch: the next tiles of a shuffled pass over the image (None: all of it), their pixel mask, the tiles left."""
        r = self.renderer
        if self.tiles_per_step == len(r.all_tiles):
            return None, None, order
        if len(order) < self.tiles_per_step:
            order = self.rng.permutation(len(r.all_tiles)).astype(np.int32)
        tiles, order = np.sort(order[: self.tiles_per_step]), order[self.tiles_per_step :]
        return tiles, self.pixel_mask(tiles), order

    def _log_row(self, step: int, seconds: float, params: GaussParams, loss: float, value: float) -> dict:
        return {
            "step": step,
            "epoch": step / self.steps_per_epoch,
            "seconds": seconds,
            "splats": params.n,
            "loss": loss,
            "psnr": value,
        }

    def _log_step(self, log: list, bar, params: GaussParams, step: int, start: float, loss: float, image, mask) -> None:
        """Log a step: the whole image's PSNR (rendered again after a mini-batch step)."""
        value = psnr(image, self.target) if mask is None else psnr(self.renderer.forward(params).image, self.target)
        log.append(self._log_row(step, time.perf_counter() - start, params, loss, value))
        if bar is not None:
            bar.set_postfix(loss=f"{loss:.3g}", psnr=f"{value:.2f}", n=params.n, refresh=False)

    def _finish(self, params: GaussParams, step: int, start: float, log: list) -> FitResult:
        """The final model's image and PSNR, and its log row."""
        image = self.renderer.forward(params).image
        final = psnr(image, self.target)
        seconds = time.perf_counter() - start
        row = self._log_row(step, seconds, params, loss_and_grad(self.config.loss, image, self.target)[0], final)
        # one row per step: a run ending on a logged step measured that step before its update,
        # the final model after it; the last row is the final model's, as FitResult reports it
        if log and log[-1]["step"] == step:
            log[-1] = row
        else:
            log.append(row)
        return FitResult(params, image, final, step, seconds, log)

    def _project(self, params: GaussParams) -> None:
        """Keep parameters where the model is meaningful."""
        np.clip(params.opacity, 0.0, 1.0, out=params.opacity)
        np.clip(params.log_scale, MIN_LOG_SCALE, np.log(max(self.width, self.height) / 2), out=params.log_scale)
        np.clip(params.xy, 0.0, [self.width, self.height], out=params.xy)
        np.clip(params.lum, 0.0, None, out=params.lum)


def fit(device, target: np.ndarray, config: FitConfig | None = None, **overrides) -> FitResult:
    """Fit splats to `target`; keyword overrides set FitConfig fields."""
    config = replace(config or FitConfig(), **overrides)  # the caller's config stays as it was
    return Fitter(device, target, config).run()
