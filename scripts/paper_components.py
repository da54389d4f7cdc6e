"""The paper's variance components of its primary contrast, from what it
publishes (../shared/paper/NUMBERS.md; Shulman 2026, Table 2 and the
appendix), for `crossaudit plan --components`.

The primary (world model, 1 s) has d's 95% interval [-0.0735, 0.0011] m
from the crossed method of moments with t(J - 1) df over I = 26
recordings and J = 20 seeds, so SE = width / (2 t(19)) and d is the
interval's midpoint; the shares of SE^2 are 95.9 / 1.1 / 3.0 % (recording
/ seed / residual), and SE^2 = s_rec / I + s_seed / J + s_res / (I J), so
s_rec = 0.959 SE^2 I, s_seed = 0.011 SE^2 J, s_res = 0.030 SE^2 I J. The
reference (disjoint) mean is 0.299 m. The paper rounds to 4 decimals and
the shares to 0.1 %, so these are good to about 3 significant digits.

Prints the arguments: python3 scripts/paper_components.py
"""

I, J = 26, 20
LOWER, UPPER = -0.0735, 0.0011
SHARES = (0.959, 0.011, 0.030)
REFERENCE_MEAN = 0.299
# t(19) 0.975 quantile (R: qt(0.975, 19) = 2.093024054408263).
T19 = 2.093024054408263

se = (UPPER - LOWER) / (2 * T19)
d = (LOWER + UPPER) / 2
s_rec, s_seed, s_res = SHARES[0] * se**2 * I, SHARES[1] * se**2 * J, SHARES[2] * se**2 * I * J
print(
    f"--components recording={s_rec:.6g},seed={s_seed:.6g},residual={s_res:.6g} "
    f"--effect={d:.6g} --reference-mean {REFERENCE_MEAN}"
)
