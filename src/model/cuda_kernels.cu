// The elementwise work of the CUDA trainer (src/model/cuda.rs), compiled at
// run time by NVRTC with fused multiply-add contraction off (fmad=false),
// so that each element gets the operations of the fused CPU trainer
// (src/model/fused.rs) in the same order. K jobs are laid out one after
// another: a [K][n][w] buffer holds job k's n x w matrix at k * n * w.
// No reduction uses atomics: a sum over rows runs in row order in one
// thread, and a job's loss is reduced in a fixed tree in one block, so a
// rerun on the same GPU gives the same bits.

// z[k][i][j] = act(z[k][i][j] + bias[k][j]): ReLU for hidden layers.
extern "C" __global__ void bias_act(float* z, const float* bias, long long k, long long n, long long w, int relu) {
    long long total = k * n * w;
    for (long long e = blockIdx.x * (long long)blockDim.x + threadIdx.x; e < total;
         e += (long long)gridDim.x * blockDim.x) {
        long long job = e / (n * w);
        long long j = e % w;
        float zb = z[e] + bias[job * w + j];
        z[e] = relu ? fmaxf(zb, 0.0f) : zb;
    }
}

// The MSE's gradient of each prediction: 0 + (d + d) * inv_n, d = p - t.
extern "C" __global__ void mse_grad(const float* pred, const float* y, float* grad, long long total, float inv_n) {
    for (long long e = blockIdx.x * (long long)blockDim.x + threadIdx.x; e < total;
         e += (long long)gridDim.x * blockDim.x) {
        float d = pred[e] - y[e];
        grad[e] = 0.0f + (d + d) * inv_n;
    }
}

// Through the ReLU: g = 0 + df * g, df = 1 where the layer's output h > 0.
extern "C" __global__ void relu_back(float* g, const float* h, long long total) {
    for (long long e = blockIdx.x * (long long)blockDim.x + threadIdx.x; e < total;
         e += (long long)gridDim.x * blockDim.x) {
        float df = h[e] > 0.0f ? 1.0f : 0.0f;
        g[e] = 0.0f + df * g[e];
    }
}

// gb[k][j] = sum over rows i, in row order, of g[k][i][j] (one thread each).
extern "C" __global__ void bias_grad(const float* g, float* gb, long long k, long long n, long long w) {
    long long t = blockIdx.x * (long long)blockDim.x + threadIdx.x;
    if (t >= k * w) return;
    long long job = t / w, j = t % w;
    const float* base = g + job * n * w + j;
    float s = 0.0f;
    for (long long i = 0; i < n; i++) s += base[i * w];
    gb[t] = s;
}

// Job blockIdx.x's sum of squared differences over its len elements, in
// f32 (the training loss) and in f64 (the validation loss), by a fixed
// tree over 256 threads.
extern "C" __global__ void sq_err(const float* pred, const float* y, long long len, float* out32, double* out64) {
    __shared__ double part[256];
    long long job = blockIdx.x;
    const float* p = pred + job * len;
    const float* t = y + job * len;
    double s = 0.0;
    for (long long e = threadIdx.x; e < len; e += blockDim.x) {
        double d = (double)(p[e] - t[e]);
        s += d * d;
    }
    part[threadIdx.x] = s;
    __syncthreads();
    for (int half = blockDim.x / 2; half > 0; half /= 2) {
        if (threadIdx.x < half) part[threadIdx.x] += part[threadIdx.x + half];
        __syncthreads();
    }
    if (threadIdx.x == 0) {
        out32[job] = (float)part[0];
        out64[job] = part[0];
    }
}

// dfdx's Adam step (no weight decay) on every job whose mask is 1; c1 and
// c2 are 1 / (1 - beta^t), computed on the host as the CPU trainer does.
extern "C" __global__ void adam(float* p, const float* g, float* m, float* v, const float* mask, long long per_job,
                                long long total, float lr, float b1, float b2, float eps, float c1, float c2) {
    for (long long e = blockIdx.x * (long long)blockDim.x + threadIdx.x; e < total;
         e += (long long)gridDim.x * blockDim.x) {
        if (mask[e / per_job] == 0.0f) continue;
        float gv = g[e];
        float mv = m[e] * b1 + gv * (1.0f - b1);
        float vv = v[e] * b2 + (gv * gv) * (1.0f - b2);
        m[e] = mv;
        v[e] = vv;
        float m_hat = mv * c1;
        float v_hat = vv * c2;
        p[e] -= lr * m_hat / (sqrtf(v_hat) + eps);
    }
}
