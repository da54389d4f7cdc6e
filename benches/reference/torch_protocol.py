"""PyTorch reference of the whole protocol: every (model, arm, seed) job of
a design, exported by `cargo run --release --example export_cell` (one
directory per model and arm, named MODEL__ARM), trained as
benches/reference/torch_cell.py trains one cell (same windows, same
standardizers, same hyperparameters, early stopping, best weights
restored, then a batched rollout of the same size), on WORKERS worker
processes of one thread each. Prints one JSON line.

    python benches/reference/torch_protocol.py EXPORT_ROOT SEEDS WORKERS
    (SEEDS: comma-separated, e.g. 100,101,...)
"""
import json
import multiprocessing as mp
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def job(args):
    export_dir, seed = args
    # One fresh single-threaded process per job, as crossaudit's workers are
    # single-threaded; torch_cell.py reads the seed from cell.json, so the
    # seed is passed through the environment override below.
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", TORCH_CELL_SEED=str(seed))
    out = subprocess.run([sys.executable, os.path.join(HERE, "torch_cell.py"), export_dir, "1"],
                         capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    root, seeds, workers = sys.argv[1], [int(s) for s in sys.argv[2].split(",")], int(sys.argv[3])
    cells = sorted(d for d in os.listdir(root) if "__" in d)
    jobs = [(os.path.join(root, c), s) for c in cells for s in seeds]
    t0 = time.perf_counter()
    with mp.Pool(workers) as pool:
        results = pool.map(job, jobs, chunksize=1)
    wall = time.perf_counter() - t0
    epochs = [r["epochs"] for r in results]
    per_epoch = sum(r["seconds_per_epoch"] * r["epochs"] for r in results) / sum(epochs)
    print(json.dumps({
        "framework": results[0]["framework"], "jobs": len(results), "workers": workers, "wall_seconds": wall,
        "mean_epochs": sum(epochs) / len(epochs), "seconds_per_epoch": per_epoch,
        "train_gflops": sum(r["train_gflops"] for r in results) / len(results),
    }))


if __name__ == "__main__":
    main()
