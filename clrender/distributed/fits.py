"""Splat fits on a Dask cluster: one fit per task, results in the order given.

    results = fit_gauss([img_a, img_b], FitConfig(splats=2000, epochs=200), client=client)
    cells = splat_voronoi([img_a, img_b], VoronoiSettings(n=5000), client=client)
    runs = sweep_gauss(img_a, [FitConfig(lr=lr) for lr in (0.3, 1, 3)], client=client)

Each returns what the local call returns for each input (`clrender.splat.fit.fit`,
`clrender.splat.voronoi.splat`), bit for bit for the same seed when the run
is bounded by epochs (a --time-budget stops wherever the clock says).
Images are scattered to the cluster, not put in the task graph.
"""

from __future__ import annotations

import uuid

from . import worker
from .cluster import require_dask
from .deadlines import Deadlines
from .waiting import collect, release, scatter


def _client(client):
    from . import _client as default_client

    return default_client(client)


def _map(client, function, images, settings: list, device, desc: str, deadlines: Deadlines | None = None) -> list:
    """function(image, setting, device) on the cluster for each pair; results in order."""
    from ..progress import progress

    require_dask()
    client = _client(client)
    scattered = scatter(client, list(images), deadlines=deadlines)
    token = uuid.uuid4().hex[:12]
    futures = [
        client.submit(function, image, setting, device, key=f"clrender-{desc}-{token}-{i}")
        for i, (image, setting) in enumerate(zip(scattered, settings))
    ]
    results = [None] * len(futures)
    try:
        with progress(total=len(futures), desc=desc, unit="fit") as bar:
            for i, result in collect(client, futures, desc, deadlines):
                results[i] = result
                bar.update()
    finally:  # Ctrl-C or a failed fit: drop what is left and the images
        release(futures + scattered)
    return results


def fit_gauss(targets, config=None, client=None, device=None, deadlines: Deadlines | None = None) -> list:
    """Fit Gaussian splats to each (H, W, 3) float32 target: a FitResult each, as `fit(device, target, config)`."""
    from ..splat.fit import FitConfig

    targets = list(targets)
    config = config or FitConfig()
    return _map(client, worker.fit_gauss, targets, [config] * len(targets), device, "gauss", deadlines)


def sweep_gauss(target, configs, client=None, device=None, deadlines: Deadlines | None = None) -> list:
    """One fit of `target` per FitConfig (a hyper-parameter sweep): a FitResult each, in order."""
    configs = list(configs)
    return _map(client, worker.fit_gauss, [target] * len(configs), configs, device, "sweep", deadlines)


def splat_voronoi(images, settings=None, client=None, device=None, deadlines: Deadlines | None = None) -> list:
    """Voronoi splatting of each image: a VoronoiResult each, as `splat(device, image, settings)`."""
    from ..splat.voronoi import VoronoiSettings

    images = list(images)
    settings = settings or VoronoiSettings()
    return _map(client, worker.splat_voronoi, images, [settings] * len(images), device, "voronoi", deadlines)
