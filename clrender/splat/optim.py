"""First-order optimisers in numpy, with one learning rate per parameter group.

`step(params, grads)` updates the arrays of `params` (a dict name -> array) in
place for the groups it was given rates for; `reindex(src)` keeps the state
consistent when densification rebuilds the splat list (new row i continues
from old row src[i]).

    sgd:      p -= lr g                                  (plain gradient descent)
    momentum: v = mu v + g;  p -= lr v                   (mu = 0.9)
    adam:     m = b1 m + (1-b1) g;  v = b2 v + (1-b2) g^2;
              p -= lr m_hat / (sqrt(v_hat) + eps)         (b1 0.9, b2 0.999, eps 1e-8)
"""

from __future__ import annotations

import numpy as np

from ..errors import UsageError

OPTIMIZERS = ("sgd", "momentum", "adam")


class Optimizer:
    def __init__(self, kind: str, lrs: dict[str, float], *, momentum: float = 0.9, betas=(0.9, 0.999), eps: float = 1e-8):
        if kind not in OPTIMIZERS:
            raise UsageError(f"optimizer {kind!r} is unknown; allowed: {', '.join(OPTIMIZERS)}")
        self.kind, self.lrs = kind, dict(lrs)
        self.momentum, self.betas, self.eps = momentum, betas, eps
        self.state: dict[str, list[np.ndarray]] = {}
        self.t = 0

    def step(self, params: dict[str, np.ndarray], grads: dict[str, np.ndarray]) -> None:
        self.t += 1
        for name, lr in self.lrs.items():
            p, g = params[name], grads[name].astype(np.float32, copy=False)
            if self.kind == "sgd":
                p -= lr * g
                continue
            st = self.state.get(name)
            if st is None or st[0].shape != p.shape:
                st = self.state[name] = [np.zeros_like(p), np.zeros_like(p)]
            if self.kind == "momentum":
                st[0] *= self.momentum
                st[0] += g
                p -= lr * st[0]
            else:
                b1, b2 = self.betas
                m, v = st
                m *= b1
                m += (1 - b1) * g
                v *= b2
                v += (1 - b2) * g * g
                m_hat = m / (1 - b1**self.t)
                v_hat = v / (1 - b2**self.t)
                p -= lr * m_hat / (np.sqrt(v_hat) + self.eps)

    def reindex(self, src: np.ndarray) -> None:
        """Row i of every state array now continues old row src[i]."""
        for st in self.state.values():
            for k, a in enumerate(st):
                st[k] = a[src]
