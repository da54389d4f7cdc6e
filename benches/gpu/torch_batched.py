"""PyTorch's time for the batched work crossaudit's CUDA trainer does: K
independent MLPs of the paper's shape (18 -> 256 -> 256 -> 256 -> 14, ReLU)
trained at once with batched matrix products, each on its own data, Adam
(lr 1e-3, dfdx's defaults), cosine schedule, batch 1024, 16,000 fit
windows and 2,000 validation windows each, EPOCHS epochs with a
validation pass after each. Data are random (the time does not depend on
them); every job keeps its own shuffle. fp32, TF32 off unless --tf32.

    python3 benches/gpu/torch_batched.py K [EPOCHS] [--tf32]

Prints one line: K, epochs, seconds (training and validation, after one
warm-up step), the device's name.
"""
import math
import sys
import time

import torch

args = [a for a in sys.argv[1:] if not a.startswith("--")]
K = int(args[0]) if args else 80
EPOCHS = int(args[1]) if len(args) > 1 else 100
tf32 = "--tf32" in sys.argv
torch.backends.cuda.matmul.allow_tf32 = tf32
torch.backends.cudnn.allow_tf32 = tf32
dev = torch.device("cuda")
torch.manual_seed(0)
N, NV, B, IN, OUT, H = 16000, 2000, 1024, 18, 14, 256
sizes = [IN, H, H, H, OUT]
params = []
for i, o in zip(sizes[:-1], sizes[1:]):
    b = 1.0 / math.sqrt(i)
    params.append((torch.empty(K, o, i, device=dev).uniform_(-b, b).requires_grad_(),
                   torch.empty(K, 1, o, device=dev).uniform_(-b, b).requires_grad_()))
flat = [p for pair in params for p in pair]
opt = torch.optim.Adam(flat, lr=1e-3)
x = torch.randn(K, N, IN, device=dev)
y = torch.randn(K, N, OUT, device=dev)
xv = torch.randn(K, NV, IN, device=dev)
yv = torch.randn(K, NV, OUT, device=dev)


def forward(a):
    for l, (w, b) in enumerate(params):
        a = torch.baddbmm(b, a, w.transpose(1, 2))
        if l < len(params) - 1:
            a = torch.relu(a)
    return a


def epoch(e):
    for g in opt.param_groups:
        g["lr"] = 1e-3 * 0.5 * (1 + math.cos(math.pi * e / EPOCHS))
    order = torch.argsort(torch.rand(K, N, device=dev), dim=1)
    for s in range(0, N, B):
        idx = order[:, s:s + B]
        xb = torch.gather(x, 1, idx.unsqueeze(-1).expand(-1, -1, IN))
        yb = torch.gather(y, 1, idx.unsqueeze(-1).expand(-1, -1, OUT))
        loss = ((forward(xb) - yb) ** 2).mean(dim=(1, 2)).sum()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
    with torch.no_grad():
        return ((forward(xv) - yv) ** 2).mean(dim=(1, 2)).cpu()


epoch(0)  # warm-up: kernels chosen, memory allocated
torch.cuda.synchronize()
t0 = time.perf_counter()
for e in range(EPOCHS):
    epoch(e)
torch.cuda.synchronize()
print(f"torch batched: K={K} epochs={EPOCHS} {time.perf_counter() - t0:.1f} s "
      f"({'tf32' if tf32 else 'fp32'}) on {torch.cuda.get_device_name(0)}, torch {torch.__version__}")
