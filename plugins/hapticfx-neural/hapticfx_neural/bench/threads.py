"""`hapticfx bench threads`: torch intra-op threads against speed, for inference and training.

Picks the default of ``threads`` (interpolator options and training configs): on a
machine whose cores are shared, extra threads can spin-wait for each other and
lose. Every figure comes from this run; thread counts take turns so that a change
in machine load falls on all of them alike.
"""

from __future__ import annotations

import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import typer

from hapticfx.timing import Timing, ms, table

SHIPPED_CONFIG = Path(__file__).resolve().parent.parent / "configs" / "helmet-drops-convbilstm-pretrained.yaml"


def _inference_times(net, meta, data, counts: list[int], repeat: int) -> dict[int, list[float]]:
    import torch

    from ..training import predict

    out: dict[int, list[float]] = {n: [] for n in counts}
    for n in counts:  # warm-up at every count
        torch.set_num_threads(n)
        for _ in range(3):
            predict(net, meta, data)
    for _ in range(repeat):
        for n in counts:
            torch.set_num_threads(n)
            t0 = time.perf_counter()
            predict(net, meta, data)
            out[n].append(time.perf_counter() - t0)
    return out


def _epoch_times(cfg, data, counts: list[int], epochs: int) -> dict[int, list[float]]:
    from ..training import train_network

    out: dict[int, list[float]] = {n: [] for n in counts}
    for _ in range(epochs):
        for n in counts:
            training = {**cfg.training, "epochs": 1, "threads": n}
            _, meta = train_network(cfg.interpolator, cfg.model, training, data, progress=False,
                                    dataset_meta={"name": "bench"})
            out[n].append(meta["training"]["train_time_s"])
    return out


@contextmanager
def busy_processes(n: int):
    """``n`` processes that each keep one core busy (what a game or physics engine does beside us)."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for p in procs:
            p.kill()
            p.wait()


def threads(
    counts: str = typer.Option("1,2", "--counts", metavar="COUNT,...",
                               help="Comma-separated torch thread counts to compare."),
    repeats: int = typer.Option(50, "--repeats", metavar="COUNT", min=5,
                                help="Timed inferences per thread count (batch 1)."),
    epochs: int = typer.Option(3, "--epochs", metavar="COUNT", min=0,
                               help="Timed training epochs per thread count (0: skip)."),
    config: Path = typer.Option(SHIPPED_CONFIG, "--config", metavar="YAML",
                                help="Training configuration (default: the shipped "
                                "ConvBiLSTM's)."),
    busy: int = typer.Option(0, "--busy", metavar="COUNT", min=0, max=64,
                             help="Keep this many other processes busy while measuring "
                             "(a simulator's own threads compete for the cores too)."),
):
    """Torch threads against inference latency and training time on this machine (ratios to the first count)."""
    import torch

    from ..config import load_config
    from ..run import config_triples

    try:
        ns = [int(x) for x in counts.split(",") if x.strip()]
    except ValueError:
        raise typer.BadParameter(f"expected comma-separated integers, got {counts!r}", param_hint="--counts") from None
    if not ns or min(ns) < 1:
        raise typer.BadParameter("thread counts must be >= 1", param_hint="--counts")
    cfg = load_config(config)
    datasets, data, _ = config_triples(cfg)
    dataset = datasets[0]
    typer.echo(f"torch {torch.__version__}, {torch.get_num_threads()} threads by default on this machine; "
               f"comparing {ns} with {busy} other busy process(es)")
    with busy_processes(busy):
        results = _measure(cfg, dataset, data, ns, repeats, epochs)
    rows = [[what, n, ms(t[n].median), ms(t[n].p99), ms(t[n].iqr), f"{t[n].median / t[ns[0]].median:.2f}"]
            for what, t in results for n in ns]
    typer.echo(table(["what", "threads", "median ms", "p99 ms", "IQR ms", f"x {ns[0]} thread(s)"], rows))
    if results:
        ratio = {n: float(np.mean([t[n].median / t[ns[0]].median for _, t in results])) for n in ns}
        best = min(ns, key=ratio.get)
        typer.echo(f"fastest here: {best} thread(s) (mean ratio over the rows above: "
                   + ", ".join(f"{n}: {ratio[n]:.2f}" for n in ns) + ")")


def _measure(cfg, dataset, data, ns: list[int], repeat: int, epochs: int) -> list[tuple[str, dict[int, Timing]]]:
    from ..checkpoint import default_weights
    from ..training import load_network

    results: list[tuple[str, dict[int, Timing]]] = []
    weights = default_weights(dataset.name, cfg.reducer, cfg.interpolator)
    if weights is not None:
        net, meta = load_network(weights, arch=cfg.interpolator)
        times = _inference_times(net, meta, data.subset([0]).centres(), ns, repeat)
        results.append((f"{cfg.interpolator} inference, batch 1", {n: Timing(tuple(t)) for n, t in times.items()}))
    if epochs:
        times = _epoch_times(cfg, data, ns, epochs)
        results.append((f"{cfg.interpolator} training epoch ({len(data)} triples)",
                        {n: Timing(tuple(t)) for n, t in times.items()}))
    return results
