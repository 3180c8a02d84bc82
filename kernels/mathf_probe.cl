/* Test-only kernel: kernels/mathf.h's functions over batches of arguments, for tests/kernels/test_mathf.py
 * (through clrender/mathf_probe.py).  Needs nothing but layout.h, which mathf.h includes. */
#define DET_MATH 1
#include "mathf.h"

/* the MATHF_* function codes, in clrender/mathf_probe.py's FUNCTIONS order */
#define MATHF_SIN 0
#define MATHF_COS 1
#define MATHF_EXP 2
#define MATHF_LOG 3
#define MATHF_ATAN2 4
#define MATHF_ACOS 5
#define MATHF_ASIN 6
#define MATHF_POW 7
#define MATHF_FLOOR 8
#define MATHF_SQRT 9

/* out[i] = function `fn` of a[i] (and b[i] for atan2(a, b) and pow(a, b)) */
__kernel void mathf_probe(int n, int fn, __global const float *a, __global const float *b, __global float *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    float x = a[i], y = b[i], v;
    switch (fn) {
    case MATHF_SIN: v = sin_det(x); break;
    case MATHF_COS: v = cos_det(x); break;
    case MATHF_EXP: v = exp_det(x); break;
    case MATHF_LOG: v = log_det(x); break;
    case MATHF_ATAN2: v = atan2_det(x, y); break;
    case MATHF_ACOS: v = acos_det(x); break;
    case MATHF_ASIN: v = asin_det(x); break;
    case MATHF_POW: v = pow_det(x, y); break;
    case MATHF_FLOOR: v = floor_det(x); break;
    default: v = sqrt_det(x); break;
    }
    out[i] = v;
}

/* kernels/lanes.h's sincos_l, atan2_l, acos_l and exp_l, LANES arguments a work-item (1, 8 or 16): out[5 i] = sin a[i],
 * out[5 i + 1] = cos a[i] (|a[i]| < 256), out[5 i + 2] = atan2(a[i], b[i]), out[5 i + 3] = acos b[i], out[5 i + 4] = e^a[i] */
#include "lanes.h"
__kernel void lane_math_probe(int n, __global const float *a, __global const float *b, __global float *out) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LI i = min(base + AS_LI(LANE_IDS_L), n - 1);
    LF x = gather(a, i), y = gather(b, i), s, c, t = atan2_l(x, y), r = acos_l(y), e = exp_l(x);
    sincos_l(x, &s, &c);
    STORE_LANES(float, out, 5, base, n, s);
    STORE_LANES(float, out + 1, 5, base, n, c);
    STORE_LANES(float, out + 2, 5, base, n, t);
    STORE_LANES(float, out + 3, 5, base, n, r);
    STORE_LANES(float, out + 4, 5, base, n, e);
}
