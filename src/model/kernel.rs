//! The one matrix product of the fused trainer: a bounds-checked, safe
//! wrapper around `gemm` 0.19, whose `x86-v4` build picks AVX-512 kernels at
//! run time (and AVX2 or scalar kernels on CPUs without them).
//!
//! Every call is issued with exactly the arguments dfdx 0.13 passes to
//! `gemm` 0.15 for the same product (dimensions, strides, `read_dst`,
//! `alpha`, `beta`), so each output element is reduced in the same order.
#![allow(unsafe_code)]

/// A strided matrix operand: element (i, j) is at `i * rs + j * cs`.
#[derive(Clone, Copy)]
pub(super) struct Strided<'a> {
    pub data: &'a [f32],
    pub rs: usize,
    pub cs: usize,
}

/// The last index an `rows x cols` operand with these strides touches.
fn last_index(rows: usize, cols: usize, rs: usize, cs: usize) -> usize {
    (rows - 1) * rs + (cols - 1) * cs
}

/// `dst = alpha * dst + beta * lhs * rhs` for an `m x k` lhs and a `k x n`
/// rhs, as `gemm::gemm` computes it, on one thread. `read_dst == false`
/// ignores the old contents of `dst`.
///
/// Panics if an operand's slice is shorter than its shape and strides need
/// (a bug in the caller, never a data error).
#[allow(clippy::too_many_arguments)]
pub(super) fn gemm(
    (m, n, k): (usize, usize, usize),
    dst: &mut [f32],
    (dst_rs, dst_cs): (usize, usize),
    read_dst: bool,
    lhs: Strided<'_>,
    rhs: Strided<'_>,
    alpha: f32,
    beta: f32,
) {
    if m == 0 || n == 0 {
        return;
    }
    assert!(last_index(m, n, dst_rs, dst_cs) < dst.len(), "gemm: destination too short");
    if k > 0 {
        assert!(last_index(m, k, lhs.rs, lhs.cs) < lhs.data.len(), "gemm: lhs too short");
        assert!(last_index(k, n, rhs.rs, rhs.cs) < rhs.data.len(), "gemm: rhs too short");
    }
    // SAFETY: the assertions above keep every index gemm reads or writes
    // (row * rs + col * cs over the declared shapes) inside the slices;
    // `dst` is exclusively borrowed and cannot alias `lhs` or `rhs`.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            dst_cs as isize,
            dst_rs as isize,
            read_dst,
            lhs.data.as_ptr(),
            lhs.cs as isize,
            lhs.rs as isize,
            rhs.data.as_ptr(),
            rhs.cs as isize,
            rhs.rs as isize,
            alpha,
            beta,
            false,
            false,
            false,
            gemm::Parallelism::None,
        )
    }
}
