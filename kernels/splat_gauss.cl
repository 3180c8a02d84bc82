/* 2D Gaussian splats: tile-binned forward pass and per-(tile, splat) backward pass.
 *
 * Buffers (records declared in clrender/layout.py; splat_prepare and the binning
 * kernels fill the splat and tile buffers from the parameters clrender/splat/gauss.py uploads):
 *   params     SplatParams per splat, as the host holds it (centre, log-scales, rotation, ...).
 *   splats     GaussSplat per splat: its centre (mx, my), the quadratic form
 *              q(p) = A dx^2 + B2 dx dy + C dy^2 with (dx, dy) = p - m of the inverse
 *              covariance S^-1 (B2 = 2 * off-diagonal), its opacity and log2 of it, and row_shift,
 *              row_q: each row's parabola in x (splat_forward).
 *   colors     SplatColor per splat: (r, g, b), the effective colour.
 *   bbox       SplatBox per splat: pixel range [x0, x1) x [y0, y1) holding the 3-sigma
 *              ellipse (q < 9), clipped to the image.
 *   partial    SplatGrad per (tile, splat) entry of the backward pass.
 *   tile_start int per tile + 1: splats of tile t are tile_splats[tile_start[t] ..
 *              tile_start[t+1]), in increasing splat index.
 *   tiles      int per forward work-item: which tile it renders.
 *   images     `pitch` x `rows` pixels, pitch = 16 * tiles_x and rows = 16 * tiles_y
 *              (padded to whole tiles); the forward pass writes colour as interleaved
 *              rgb floats and the sum of weights as one float per pixel, the backward
 *              pass reads 4 float planes (r, g, b, 4th) of `pitch` x `rows` floats.
 * Pixel (px, py) has its centre at (px + 0.5, py + 0.5).
 *
 * Weight of splat i at a pixel: w_i = o_i exp(-q_i / 2) where q_i < 9, else 0.
 * BLEND_NORMALIZED 0 ("sum"):       I = bg + sum_i w_i c_i
 * BLEND_NORMALIZED 1 ("normalized"): I = (sum_i w_i c_i + SPLAT_EPS bg) / (sum_i w_i + SPLAT_EPS)
 * so where no splat reaches, a normalized pixel fades to the background colour.
 *
 * Pixels are processed 8 at a time as float8 vectors (one AVX register on a
 * CPU), so PoCL runs 8 SIMD lanes per splat.
 */
/* mathf.h's exp, sin, cos, log and sqrt (the builtins' last bits are each driver's own), compiled without contraction
 * as everywhere.  This file's own a * b + c stay contracted into fma (FP_CONTRACT ON): uncontracted, a forward pass took
 * 1.3x and a training step 1.9x the time.  Intel's runtime, PoCL and Oclgrind all fuse them, and give the same bits
 * (tests/kernels/test_same_bits_drivers.py); a driver for hardware without fma would round them twice. */
#define DET_MATH 1
#include "mathf.h"
#pragma OPENCL FP_CONTRACT ON
/* SPLAT_TILE, SPLAT_EPS (the background's weight), the records */
#include "layout.h"

#ifndef BLEND_NORMALIZED
#define BLEND_NORMALIZED 0
#endif
#define VW 8            /* pixels per work-item */
#define CUTOFF_Q 9.0f   /* 3 sigma */
#define NEG_HALF_LOG2E (-0.72134752f)  /* exp(-q / 2) = 2^(NEG_HALF_LOG2E q) */

#define LANES ((float8)(0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f))

/* PoCL leaves builtins such as floor, fmax, select and any() as calls, which cost
 * more than the arithmetic around them; these inline forms use only operators. */

/* 2^y for y in [-126, 0] (other lanes give garbage, to be masked off): y = n + f with
 * n rounded to nearest by the 1.5 * 2^23 shifter, f in [-0.5, 0.5], p a degree-5 fit
 * of 2^f (relative error < 2e-7).  Eleven vector operations and the same result on
 * every driver; PoCL's exp is a call that costs several times more. */
inline float8 exp2_fast(const float8 y)
{
    const float8 shifter = 12582912.0f;
    const float8 t = y + shifter;          /* n sits in the low mantissa bits of t */
    const float8 f = y - (t - shifter);
    float8 p = 0.00132764725f;
    p = p * f + 0.00967554189f;
    p = p * f + 0.0555071309f;
    p = p * f + 0.240221202f;
    p = p * f + 0.693146944f;
    p = p * f + 1.00000012f;
    return p * as_float8((as_int8(t) - (0x4B400000 - 127)) << 23);
}

/* any(m) without the builtin call */
inline bool any8(const int8 m)
{
    const int4 a = m.lo | m.hi;
    const int2 b = a.lo | a.hi;
    return (b.x | b.y) < 0;
}

inline float hsum8(const float8 v)
{
    const float4 a = v.lo + v.hi;
    const float2 b = a.lo + a.hi;
    return b.x + b.y;
}

/* Work-item i packs splat i from its parameters into splats, colors and bbox. */
__kernel void splat_prepare(__global const SplatParams *params, const int n, const int width,
                            const int height, __global GaussSplat *splats, __global SplatColor *colors,
                            __global SplatBox *bbox)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    __global const SplatParams *p = params + i;
    const float mx = p->xy[0], my = p->xy[1];
    const float sx2 = EXP(2.0f * p->log_scale[0]), sy2 = EXP(2.0f * p->log_scale[1]);
    const float det = EXP(2.0f * (p->log_scale[0] + p->log_scale[1]));  /* sx^2 sy^2, without cancellation */
    float c, s;
    SINCOS(p->theta, s, c);
    /* covariance S = R diag(sx^2, sy^2) R^T */
    const float sxx = c * c * sx2 + s * s * sy2, sxy = c * s * (sx2 - sy2), syy = s * s * sx2 + c * c * sy2;
    __global GaussSplat *splat = splats + i;
    splat->mx = mx;
    splat->my = my;
    splat->A = syy / det;
    splat->B2 = -2.0f * sxy / det;
    splat->C = sxx / det;
    splat->opacity = p->opacity;
    splat->log2_opacity = p->opacity > 0x1p-100f ? LOG(p->opacity) * M_LOG2E_F : -100.0f; /* keeps 2^y normal */
    splat->row_shift = sxy / syy;
    splat->row_q = 1.0f / syy;
    __global SplatColor *color = colors + i;
    color->r = p->color[0] * p->lum;
    color->g = p->color[1] * p->lum;
    color->b = p->color[2] * p->lum;
    /* pixels whose centres may lie in the ellipse q = 9: half extents 3 sqrt(Sxx) and
     * 3 sqrt(Syy), plus a hair for rounding; fmin/fmax also turn a NaN into an edge */
    const float rx = 3.0f * SQRT(sxx) + 1e-3f, ry = 3.0f * SQRT(syy) + 1e-3f;
    const float w = width, h = height;
    __global SplatBox *box = bbox + i;
    box->x0 = (int)fmin(fmax(ceil(mx - rx - 0.5f), 0.0f), w);
    box->y0 = (int)fmin(fmax(ceil(my - ry - 0.5f), 0.0f), h);
    box->x1 = (int)fmin(fmax(floor(mx + rx + 0.5f), 0.0f), w);
    box->y1 = (int)fmin(fmax(floor(my + ry + 0.5f), 0.0f), h);
}

/* The tile columns [tx0, tx1] of a splat's box if it reaches tile row ty, else false. */
inline bool box_in_tile_row(const SplatBox box, const int ty, int *tx0, int *tx1)
{
    const bool empty = box.x1 <= box.x0 || box.y1 <= box.y0;
    if (empty || box.y0 >= (ty + 1) * SPLAT_TILE || box.y1 <= ty * SPLAT_TILE) return false;
    *tx0 = box.x0 / SPLAT_TILE;
    *tx1 = (box.x1 - 1) / SPLAT_TILE;
    return true;
}

/* Binning, one work-item per tile row ty (so no two work-items share a tile and no
 * atomics are needed): count the splats of each tile of the row ... */
__kernel void splat_bin_count(__global const SplatBox *bbox, const int n, const int tiles_x,
                              __global int *count)
{
    __global int *row = count + get_global_id(0) * tiles_x;
    for (int tx = 0; tx < tiles_x; ++tx) row[tx] = 0;
    int tx0, tx1;
    for (int i = 0; i < n; ++i)
        if (box_in_tile_row(bbox[i], get_global_id(0), &tx0, &tx1))
            for (int tx = tx0; tx <= tx1; ++tx) row[tx]++;
}

/* ... then, with cursor = tile_start (the host's prefix sum of count), list them in
 * increasing splat index: tile t's splats end up in tile_splats[tile_start[t] ..). */
__kernel void splat_bin_fill(__global const SplatBox *bbox, const int n, const int tiles_x,
                             __global int *cursor, __global int *tile_splats)
{
    __global int *row = cursor + get_global_id(0) * tiles_x;
    int tx0, tx1;
    for (int i = 0; i < n; ++i)
        if (box_in_tile_row(bbox[i], get_global_id(0), &tx0, &tx1))
            for (int tx = tx0; tx <= tx1; ++tx) tile_splats[row[tx]++] = i;
}

/* Blend one splat into 8 pixels of row r, half h of the tile: fx their centres.
 * Along the row log2(w) = a (x - xc)^2 + ymin (see splat_forward). */
#define BLEND_INTO(fx, h)                                              \
    {                                                                  \
        const float8 u = (fx) - xc;                                    \
        const float8 y = a * u * u + ymin;                             \
        const float8 w = y > ycut ? exp2_fast(y) : 0.0f;               \
        sum_r[2 * r + h] += w * c.r;                                   \
        sum_g[2 * r + h] += w * c.g;                                   \
        sum_b[2 * r + h] += w * c.b;                                   \
        sum_w[2 * r + h] += w;                                         \
    }

/* Work-item n renders tile tiles[n]: each splat of the tile's list is blended into
 * the rows of its 3-sigma box, as two float8 halves per row (only the halves the
 * box reaches).  On row y (dy = y + 0.5 - my) a splat's q is a parabola in x,
 * A (x - xc)^2 + row_q dy^2 with xc = mx + row_shift dy (row_q = 1 / Syy, row_shift = Sxy / Syy), so
 * log2(w) = log2(o) - log2(e) q / 2 costs three scalar operations per row and two
 * vector ones per pixel, and q < 9 becomes log2(w) > ycut.
 * Looping over splats outside rows reads each splat once per tile and keeps the
 * branches predictable: a per-row test of every splat cost twice as much on a CPU.
 * image: I.rgb interleaved, weight: sum of w, both `pitch` x `rows` pixels. */
__kernel void splat_forward(__global const GaussSplat *splats, __global const SplatColor *colors,
                            __global const SplatBox *bbox, __global const int *tile_start,
                            __global const int *tile_splats, __global const int *tiles,
                            const int tiles_x, const float4 background,
                            __global float *image, __global float *weight)
{
    const int t = tiles[get_global_id(0)];
    const int pitch = tiles_x * SPLAT_TILE;
    const int x0 = (t % tiles_x) * SPLAT_TILE, y0 = (t / tiles_x) * SPLAT_TILE;
    const float8 fx_lo = (float)x0 + 0.5f + LANES, fx_hi = fx_lo + 8.0f;
    /* per tile row r, halves 2r and 2r + 1 */
    float8 sum_r[2 * SPLAT_TILE], sum_g[2 * SPLAT_TILE], sum_b[2 * SPLAT_TILE], sum_w[2 * SPLAT_TILE];
    for (int j = 0; j < 2 * SPLAT_TILE; ++j) sum_r[j] = sum_g[j] = sum_b[j] = sum_w[j] = 0.0f;
    const int end = tile_start[t + 1];
    for (int k = tile_start[t]; k < end; ++k) {
        const int i = tile_splats[k];
        const GaussSplat s = splats[i];
        const SplatColor c = colors[i];
        const SplatBox box = bbox[i];
        const int r0 = max(box.y0, y0) - y0, r1 = min(box.y1, y0 + SPLAT_TILE) - y0;
        const bool lo = box.x0 < x0 + VW, hi = box.x1 > x0 + VW;
        const float a = NEG_HALF_LOG2E * s.A, k_dy2 = NEG_HALF_LOG2E * s.row_q;
        const float log2_o = s.log2_opacity;
        const float ycut = log2_o + NEG_HALF_LOG2E * CUTOFF_Q;
        for (int r = r0; r < r1; ++r) {
            const float dy = y0 + r + 0.5f - s.my;
            const float ymin = k_dy2 * dy * dy + log2_o;
            const float xc = s.mx + s.row_shift * dy;
            if (lo) BLEND_INTO(fx_lo, 0)
            if (hi) BLEND_INTO(fx_hi, 1)
        }
    }
    for (int j = 0; j < 2 * SPLAT_TILE; ++j) {
        const int pixel = (y0 + j / 2) * pitch + x0 + (j % 2) * VW;
        float8 R = sum_r[j], G = sum_g[j], B = sum_b[j];
#if BLEND_NORMALIZED
        const float8 n = 1.0f / (sum_w[j] + SPLAT_EPS);
        R = (R + SPLAT_EPS * background.x) * n;
        G = (G + SPLAT_EPS * background.y) * n;
        B = (B + SPLAT_EPS * background.z) * n;
#else
        R += background.x; G += background.y; B += background.z;
#endif
        /* rows are whole tiles wide, so these are aligned float8 stores */
        __global float8 *rgb = (__global float8 *)(image + 3 * pixel);
        rgb[0] = (float8)(R.s0, G.s0, B.s0, R.s1, G.s1, B.s1, R.s2, G.s2);
        rgb[1] = (float8)(B.s2, R.s3, G.s3, B.s3, R.s4, G.s4, B.s4, R.s5);
        rgb[2] = (float8)(G.s5, B.s5, R.s6, G.s6, B.s6, R.s7, G.s7, B.s7);
        *(__global float8 *)(weight + pixel) = sum_w[j];
    }
}

/* One work-item per (tile, splat) entry: the splat's gradient summed over the
 * pixels of that tile inside its 3-sigma box.  Entries never share an output
 * row, so there are no races; the host sums rows per splat.
 * dimg: 4 planes (g.rgb, k) such that dL/dc_i = g w_i and dL/dw_i = g . c_i - k
 * at each pixel (see gauss.py: pixel_adjoint); zero in the padding.
 * partial: one SplatGrad per entry. */
__kernel void splat_backward(__global const GaussSplat *splats, __global const SplatColor *colors,
                             __global const SplatBox *bbox, __global const int *entry_splat,
                             __global const int *entry_tile, const int n_entries,
                             const int tiles_x, const int plane,
                             __global const float *dimg, __global SplatGrad *partial)
{
    const int e = get_global_id(0);
    if (e >= n_entries) return;
    const int i = entry_splat[e], t = entry_tile[e];
    const int pitch = tiles_x * SPLAT_TILE;
    const GaussSplat s = splats[i];
    const SplatColor c = colors[i];
    const SplatBox box = bbox[i];
    const int tx = (t % tiles_x) * SPLAT_TILE, ty = (t / tiles_x) * SPLAT_TILE;
    const int y0 = max(box.y0, ty), y1 = min(box.y1, ty + SPLAT_TILE);
    float8 gmx = (float8)(0.0f), gmy = gmx, gA = gmx, gB = gmx, gC = gmx;
    float8 gr = gmx, gg = gmx, gb = gmx, go = gmx, wsum = gmx;
    for (int x0 = tx; x0 < tx + SPLAT_TILE; x0 += VW) {
        const bool outside_box = x0 + VW <= box.x0 || x0 >= box.x1;
        if (outside_box) continue;
        /* columns inside the splat's box, as a lane mask */
        const int8 lane = (int8)(0, 1, 2, 3, 4, 5, 6, 7) + x0;
        const int8 in_box = (lane >= box.x0) & (lane < box.x1);
        const float8 dx = (float)x0 + 0.5f + LANES - s.mx;
        for (int py = y0; py < y1; ++py) {
            const float dy = py + 0.5f - s.my;
            const float8 q = (s.A * dx + s.B2 * dy) * dx + s.C * dy * dy;
            const int8 inside = (q < CUTOFF_Q) & in_box;
            if (!any8(inside)) continue;
            const float8 g = inside ? exp2_fast(NEG_HALF_LOG2E * q) : 0.0f;  /* exp(-q / 2) */
            const float8 w = s.opacity * g;
            __global const float *d = dimg + py * pitch + x0;
            const float8 d_r = vload8(0, d), d_g = vload8(0, d + plane), d_b = vload8(0, d + 2 * plane);
            const float8 dLdw = d_r * c.r + d_g * c.g + d_b * c.b - vload8(0, d + 3 * plane);
            const float8 dLdq = -0.5f * dLdw * w;
            gr += d_r * w;
            gg += d_g * w;
            gb += d_b * w;
            go += dLdw * g;
            gA += dLdq * dx * dx;
            gB += dLdq * dx * dy;
            gC += dLdq * dy * dy;
            /* dq/dm = -(dq/d(dx), dq/d(dy)) */
            gmx -= dLdq * (2.0f * s.A * dx + s.B2 * dy);
            gmy -= dLdq * (s.B2 * dx + 2.0f * s.C * dy);
            wsum += w;
        }
    }
    __global SplatGrad *out = partial + e;
    out->mean[0] = hsum8(gmx); out->mean[1] = hsum8(gmy);
    out->A = hsum8(gA); out->B2 = hsum8(gB); out->C = hsum8(gC);
    out->color[0] = hsum8(gr); out->color[1] = hsum8(gg); out->color[2] = hsum8(gb);
    out->opacity = hsum8(go); out->weight = hsum8(wsum);
}
