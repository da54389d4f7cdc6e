"""Fit the external models of an export and write their rollouts as
predictions for `crossaudit score`.

    python train.py DIR [--models gru,residual] [--epochs 100] [--threads 1]
                        [--jobs-from K --jobs-step N]

DIR is the run directory `crossaudit export DESIGN --out DIR` wrote. For
every external job (model x arm x seed) of DIR/export/export.json whose
model this script knows, it trains with the job's seed on the arm's fit
windows under the paper's schedule (Adam, lr 1e-3, batch 1024, cosine
decay, early stopping on the shared validation windows with patience 15,
best epoch restored), rolls the model out from every registered start and
writes DIR/predictions/MODEL__ARM__SEED.npy (starts x steps x 14, float64)
with its description MODEL__ARM__SEED.json, and a training log in
DIR/external_training/. A job whose predictions exist is skipped, so the
script resumes; `--jobs-from/--jobs-step` shares the jobs between
processes.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import torch

from models import DYNAMIC, MLP, GRUModel, RigidBody, Standardizer, finish_step

LR, BATCH, PATIENCE = 1e-3, 1024, 15


def load(export: Path, name: str) -> np.ndarray:
    return np.load(export / name, allow_pickle=False)


def windows(export: Path, files: dict) -> dict:
    """Arrays of the export as float64 tensors on the default device."""
    device = torch.get_default_device()
    return {k: torch.from_numpy(load(export, v)).to(device) for k, v in files.items()}


def loss_of(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    return ((pred[:, DYNAMIC] - target[:, DYNAMIC]) ** 2).mean()


def fit(model: torch.nn.Module, forward, fit_set, val_set, epochs: int, seed: int):
    """The paper's schedule: Adam, cosine decay over `epochs`, early
    stopping on validation loss (patience 15), best weights restored."""
    gen = torch.Generator().manual_seed(seed)
    opt = torch.optim.Adam(model.parameters(), lr=LR)
    n = fit_set[-1].shape[0]
    best, best_state, best_epoch, since, log = math.inf, None, 0, 0, []
    for epoch in range(1, epochs + 1):
        lr = 0.5 * LR * (1 + math.cos(math.pi * (epoch - 1) / epochs))
        for g in opt.param_groups:
            g["lr"] = lr
        model.train()
        order = torch.randperm(n, generator=gen, device="cpu").to(fit_set[0].device)
        total = 0.0
        for i in range(0, n, BATCH):
            idx = order[i : i + BATCH]
            loss = loss_of(forward(*(t[idx] for t in fit_set[:-1])), fit_set[-1][idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        model.eval()
        with torch.no_grad():
            val = loss_of(forward(*val_set[:-1]), val_set[-1]).item()
        log.append({"epoch": epoch, "lr": lr, "train_loss": total / n, "val_loss": val})
        if val < best:
            best, best_epoch, since = val, epoch, 0
            best_state = {k: v.clone() for k, v in model.state_dict().items()}
        else:
            since += 1
            if since >= PATIENCE:
                break
    model.load_state_dict(best_state)
    return {"best_epoch": best_epoch, "best_val_loss": best, "epochs_run": len(log), "curve": log}


def train_gru(export, index, job, epochs):
    std = Standardizer(job["standardizers"])
    h = job["history"]

    def sequences(files):
        w = windows(export, files)
        hist = w["history"][:, -h:, :]
        past = std.inputs(hist[..., :14], hist[..., 14:])
        now = std.inputs(w["states"], w["actions"])[:, None, :]
        return torch.cat([past, now], dim=1), std.targets(w["states"], w["next_states"])

    fx, fz = sequences(index["fit"][job["arm"]])
    vx, vz = sequences(index["validation"])
    model = GRUModel()
    info = fit(model, lambda s: model(s)[0], (fx, fz), (vx, vz), epochs, job["seed"])
    return info, gru_rollout(model, std, h), model


def gru_rollout(model, std, h):
    def rollout(starts, steps):
        with torch.no_grad():
            hist = starts["history"][:, -h:, :]
            _, hidden = model.gru(std.inputs(hist[..., :14], hist[..., 14:]))
            x = starts["states"]
            out = []
            for k in range(steps):
                z, hidden = model(std.inputs(x, starts["actions"][:, k])[:, None, :], hidden)
                x = finish_step(std.step(x, z), starts["exogenous"][:, k])
                out.append(x)
            return torch.stack(out, dim=1)

    return rollout


def train_residual(export, index, job, epochs, dt):
    std = Standardizer(job["standardizers"])
    fw = windows(export, index["fit"][job["arm"]])
    prior = RigidBody.fit(*(fw[k].cpu().numpy() for k in ("states", "actions", "next_states")), dt)

    def pairs(w):
        prior_next = prior.step(w["states"], w["actions"])
        z_true = std.targets(w["states"], w["next_states"])
        z_prior = std.targets(w["states"], prior_next)
        return std.inputs(w["states"], w["actions"]), z_true - z_prior

    fx, fz = pairs(fw)
    vx, vz = pairs(windows(export, index["validation"]))
    model = MLP()
    info = fit(model, model, (fx, fz), (vx, vz), epochs, job["seed"])
    info["prior"] = {"k1": prior.k1, "k2": prior.k2, "c": prior.c}
    rollout, _ = residual_rollout(model, std, prior)
    return info, rollout, model


def residual_rollout(model, std, prior):

    def rollout(starts, steps):
        with torch.no_grad():
            x = starts["states"]
            out = []
            for k in range(steps):
                u = starts["actions"][:, k]
                z = model(std.inputs(x, u))
                nxt = std.step(prior.step(x, u), z)
                x = finish_step(nxt, starts["exogenous"][:, k])
                out.append(x)
            return torch.stack(out, dim=1)

    return rollout, model


def rollout_of(job: dict, saved: dict, dt: float):
    """The rollout of a job's saved model (weights on the CPU, float64 states)."""
    std = Standardizer(job["standardizers"])
    if job["model"] == "gru":
        model = GRUModel()
        model.load_state_dict(saved["weights"])
        return gru_rollout(model.eval(), std, job["history"])
    model = MLP()
    model.load_state_dict(saved["weights"])
    p = saved["info"]["prior"]
    return residual_rollout(model.eval(), std, RigidBody(p["k1"], p["k2"], p["c"], dt))[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", type=Path)
    ap.add_argument("--models", default="gru,residual")
    ap.add_argument("--epochs", type=int, default=100)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--device", default="cpu", help="where to train: cpu or cuda (rollouts run on the CPU)")
    ap.add_argument("--phase", default="both", choices=["train", "predict", "both"])
    ap.add_argument("--jobs-from", type=int, default=0)
    ap.add_argument("--jobs-step", type=int, default=1)
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    if a.device == "cpu":
        torch.use_deterministic_algorithms(True)
    export = a.dir / "export"
    raw = (export / "export.json").read_bytes()
    sha = hashlib.sha256(raw).hexdigest()
    index = json.loads(raw)
    dt = 1.0 / index["rate_hz"]
    wanted = a.models.split(",")
    jobs = [j for j in index["jobs"] if j["model"] in wanted][a.jobs_from :: a.jobs_step]
    saved_dir = a.dir / "external_training"
    saved_dir.mkdir(exist_ok=True)
    if a.phase in ("train", "both"):
        torch.set_default_device(a.device)
        for job in jobs:
            stem = f"{job['model']}__{job['arm']}__{job['seed']}"
            if (saved_dir / f"{stem}.pt").exists():
                continue
            torch.manual_seed(job["seed"])
            t0 = time.time()
            with torch.device(a.device):
                if job["model"] == "gru":
                    info, _, model = train_gru(export, index, job, a.epochs)
                else:
                    info, _, model = train_residual(export, index, job, a.epochs, dt)
            info.update({"train_seconds": time.time() - t0, "device": a.device, "torch": str(torch.__version__)})
            weights = {k: v.detach().cpu() for k, v in model.state_dict().items()}
            torch.save({"weights": weights, "info": info}, saved_dir / f".{stem}.pt.tmp")
            os.replace(saved_dir / f".{stem}.pt.tmp", saved_dir / f"{stem}.pt")
            (saved_dir / f"{stem}.json").write_text(json.dumps(info, indent=1))
            print(
                f"{stem}: best epoch {info['best_epoch']} of {info['epochs_run']}, "
                f"val {info['best_val_loss']:.5f}, {info['train_seconds']:.1f} s",
                flush=True,
            )
        torch.set_default_device("cpu")
    if a.phase in ("predict", "both"):
        starts = windows(export, {k: v for k, v in index["start_files"].items() if k != "table"})
        (a.dir / "predictions").mkdir(exist_ok=True)
        for job in jobs:
            stem = f"{job['model']}__{job['arm']}__{job['seed']}"
            target = a.dir / job["predictions"]
            if target.exists():
                continue
            saved = torch.load(saved_dir / f"{stem}.pt", map_location="cpu")
            pred = rollout_of(job, saved, dt)(starts, job["steps"]).numpy().astype("<f8")
            assert list(pred.shape) == job["shape"], (pred.shape, job["shape"])
            tmp = target.parent / f".{target.name}.tmp"  # hidden: score ignores it
            with open(tmp, "wb") as f:
                np.save(f, np.ascontiguousarray(pred))
            desc = {"export_sha256": sha, "model": job["model"], "arm": job["arm"], "seed": job["seed"]}
            (a.dir / job["description"]).write_text(json.dumps(desc))
            os.replace(tmp, target)
            print(f"{stem}: predictions written", flush=True)


if __name__ == "__main__":
    main()
