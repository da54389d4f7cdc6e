"""PyTorch reference of one crossaudit training cell.

Reads the windows, standardizer and settings exported by
`cargo run --release --example export_cell` and trains the same MLP the
same way: Adam, batch, Gaussian action noise (sd from the design) on the
raw actions clipped to [0, 1] before standardization, cosine learning rate
over the epoch cap (per epoch), early stopping with patience on the
validation loss, best weights restored. Then times a batched rollout of the
same size (starts x steps forward passes). Prints one JSON line.

    python benches/reference/torch_cell.py EXPORT_DIR THREADS
"""
import copy
import json
import math
import os
import sys
import time

import numpy as np
import torch

d, threads = sys.argv[1], int(sys.argv[2])
torch.set_num_threads(threads)
meta = json.load(open(f"{d}/cell.json"))
# torch_protocol.py runs one exported (model, arm) for many seeds.
meta["seed"] = int(os.environ.get("TORCH_CELL_SEED", meta["seed"]))
torch.manual_seed(meta["seed"])
rng = np.random.default_rng(meta["seed"])


def load(name, cols):
    return torch.from_numpy(np.fromfile(f"{d}/{name}", dtype="<f4").reshape(-1, cols).copy())


fit_raw, fit_y = load("fit_raw_input.f32", 18), load("fit_target.f32", 14)
val_raw, val_y = load("val_raw_input.f32", 18), load("val_target.f32", 14)
mean = torch.tensor(meta["input_mean"], dtype=torch.float32)
std = torch.tensor(meta["input_std"], dtype=torch.float32)
val_x = (val_raw - mean) / std
w = meta["widths"]
layers, prev = [], 18
for h in w:
    layers += [torch.nn.Linear(prev, h), torch.nn.ReLU()]
    prev = h
layers.append(torch.nn.Linear(prev, 14))
net = torch.nn.Sequential(*layers)
opt = torch.optim.Adam(net.parameters(), lr=meta["lr"])
n, batch, epochs = len(fit_raw), meta["batch"], meta["epochs"]
best, best_state, since, logs = math.inf, None, 0, []
t_cell = time.perf_counter()
for epoch in range(epochs):
    t0 = time.perf_counter()
    lr = meta["lr"] * 0.5 * (1 + math.cos(math.pi * epoch / epochs)) if meta["cosine"] else meta["lr"]
    for g in opt.param_groups:
        g["lr"] = lr
    order = torch.from_numpy(rng.permutation(n))
    for k in range(0, n, batch):
        idx = order[k:k + batch]
        x = fit_raw[idx].clone()
        noise = torch.from_numpy(rng.normal(0.0, meta["action_noise"], size=(len(idx), 4)).astype(np.float32))
        x[:, 14:] = (x[:, 14:] + noise).clamp(0.0, 1.0)
        x = (x - mean) / std
        opt.zero_grad()
        loss = ((net(x) - fit_y[idx]) ** 2).mean()
        loss.backward()
        opt.step()
    with torch.no_grad():
        val = ((net(val_x) - val_y) ** 2).mean().item()
    logs.append((epoch + 1, time.perf_counter() - t0, val))
    if val < best:
        best, best_state, since = val, copy.deepcopy(net.state_dict()), 0
    else:
        since += 1
        if since >= meta["patience"]:
            break
net.load_state_dict(best_state)
cell_s = time.perf_counter() - t_cell
starts, steps = meta["rollout_starts"], meta["rollout_steps"]
x = val_x[:1].repeat(starts, 1)
t0 = time.perf_counter()
with torch.no_grad():
    for _ in range(steps):
        out = net(x)
rollout_s = time.perf_counter() - t0
macs = 18 * w[0] + sum(a * b for a, b in zip(w, w[1:])) + w[-1] * 14
epoch_s = sum(l[1] for l in logs) / len(logs)
print(json.dumps({
    "framework": f"pytorch {torch.__version__}", "threads": threads, "epochs": len(logs),
    "seconds_per_epoch": epoch_s, "seconds_per_cell": cell_s, "rollout_seconds": rollout_s,
    "train_gflops": 6 * macs * n / epoch_s / 1e9, "best_val_loss": best,
}))
