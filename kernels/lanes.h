/* A lane type: LANES paths a work-item, each in one lane of a vector register (LANES 8 or 16), or one path a
 * work-item (LANES 1), from the same source.  Code written over these types computes the same operations in the same
 * order at every width, so it gives the same bits at every width (kernels/lanes_probe.cl, docs/lanes.md):
 *   LF, LI, LU     float, int, uint lanes (float, int, uint at width 1)
 *   V3             a 3-vector of lanes, a struct of three LF (not float3: its x, y, z are each a register of lanes)
 *   masks          LI from comparisons: -1 or 0 a lane (1 or 0 at width 1); combine with & and |, negate with NOT,
 *                  test with ANY; choose with ?: on an LF or LU (or pick, on a V3), never with a branch
 *   gather         one float per lane from lane-varying indices: LANES scalar loads (OpenCL C has no gather) */
#ifndef CLRENDER_LANES_H
#define CLRENDER_LANES_H

#ifndef LANES
#define LANES 16
#endif

#if LANES == 1
typedef float LF;
typedef int LI;
typedef uint LU;
#define AS_LF(x) as_float(x)
#define AS_LU(x) as_uint(x)
#define NOT(m) (!(m))
#define ANY(m) (m)
#define CONVERT_I(x) convert_int(x)
#define LANE_IDS_L ((LU)(0U))
INLINE LF gather(__global const float *b, LI i) { return b[i]; }
INLINE LI gather_i(__global const int *b, LI i) { return b[i]; }
#else
#define LANES_CAT_(a, b) a##b
#define LANES_CAT(a, b) LANES_CAT_(a, b)
typedef LANES_CAT(float, LANES) LF;
typedef LANES_CAT(int, LANES) LI;
typedef LANES_CAT(uint, LANES) LU;
#define AS_LF(x) LANES_CAT(as_float, LANES)(x)
#define AS_LU(x) LANES_CAT(as_uint, LANES)(x)
#define NOT(m) (~(m))
#define ANY(m) any(m)
#define CONVERT_I(x) LANES_CAT(convert_int, LANES)(x)
__constant uint LANE_IDS[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
#define LANE_IDS_L LANES_CAT(vload, LANES)(0, LANE_IDS)
#if LANES == 16
#define GATHER_LANES(b, i)                                                                                             \
    (b[i.s0], b[i.s1], b[i.s2], b[i.s3], b[i.s4], b[i.s5], b[i.s6], b[i.s7], b[i.s8], b[i.s9], b[i.sa], b[i.sb], b[i.sc], \
     b[i.sd], b[i.se], b[i.sf])
#else
#define GATHER_LANES(b, i) (b[i.s0], b[i.s1], b[i.s2], b[i.s3], b[i.s4], b[i.s5], b[i.s6], b[i.s7])
#endif
INLINE LF gather(__global const float *b, LI i) { return (LF)GATHER_LANES(b, i); }
INLINE LI gather_i(__global const int *b, LI i) { return (LI)GATHER_LANES(b, i); }
#endif

typedef struct {
    LF x, y, z;
} V3;

INLINE V3 v3(LF x, LF y, LF z) { V3 v = {x, y, z}; return v; }
INLINE V3 v3_all(float s) { return v3((LF)(s), (LF)(s), (LF)(s)); }
INLINE V3 add(V3 a, V3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
INLINE V3 sub(V3 a, V3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
INLINE V3 mul(V3 a, V3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
INLINE V3 scale(LF s, V3 a) { return v3(s * a.x, s * a.y, s * a.z); }
INLINE V3 divide(V3 a, LF s) { return v3(a.x / s, a.y / s, a.z / s); }
INLINE V3 neg(V3 a) { return v3(-a.x, -a.y, -a.z); }
INLINE LF dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE V3 cross(V3 a, V3 b) { return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
INLINE LF sqrt_l(LF x) { return sqrt(x); } /* correctly rounded: the same bits at every width */
INLINE V3 unit(V3 a) { return divide(a, sqrt_l(dot(a, a))); }
INLINE V3 pick(LI m, V3 a, V3 b) { return v3(m ? a.x : b.x, m ? a.y : b.y, m ? a.z : b.z); }
INLINE LF max_l(LF a, LF b) { return a > b ? a : b; }
INLINE LF min_l(LF a, LF b) { return a < b ? a : b; }
INLINE LF max3_l(V3 a) { return max_l(a.x, max_l(a.y, a.z)); }
/* elements i, i + 1, i + 2 of b: a packed float3 per lane */
INLINE V3 gather3(__global const float *b, LI i) { return v3(gather(b, i), gather(b, i + 1), gather(b, i + 2)); }
/* lanes set in m, counted */
INLINE int lanes_set(LI m) {
#if LANES == 1
    return m != 0;
#else
    int lane[LANES], n = 0;
    LANES_CAT(vstore, LANES)(m, 0, lane);
    for (int k = 0; k < LANES; ++k) n += lane[k] != 0;
    return n;
#endif
}

#endif
