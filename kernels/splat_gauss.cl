/* 2D Gaussian splats: tile-binned forward pass and per-(tile, splat) backward pass.
 *
 * Buffer layouts (packed by clrender/splat/gauss.py, written down once here):
 *   splats     float8 per splat: (mx, my, A, B2, C, opacity, 0, 0)
 *              q(p) = A dx^2 + B2 dx dy + C dy^2 with (dx, dy) = p - m, the
 *              quadratic form of the inverse covariance (B2 = 2 * off-diagonal).
 *   colors     float4 per splat: (r, g, b, 0), the effective colour.
 *   bbox       int4 per splat: pixel range [x0, x1) x [y0, y1) holding the 3-sigma
 *              ellipse (q < 9), clipped to the image.
 *   tile_start int per tile + 1: splats of tile t are tile_splats[tile_start[t] ..
 *              tile_start[t+1]), in increasing splat index.
 *   tiles      int per work-group: which tile it renders.
 *   planes     images as 4 float planes (r, g, b, 4th) of `pitch` x `rows` floats,
 *              pitch = 16 * tiles_x and rows = 16 * tiles_y (padded to whole tiles).
 * Pixel (px, py) has its centre at (px + 0.5, py + 0.5).
 *
 * Weight of splat i at a pixel: w_i = o_i exp(-q_i / 2) where q_i < 9, else 0.
 * BLEND_NORMALIZED 0 ("sum"):       I = bg + sum_i w_i c_i
 * BLEND_NORMALIZED 1 ("normalized"): I = (sum_i w_i c_i + EPS bg) / (sum_i w_i + EPS)
 * so where no splat reaches, a normalized pixel fades to the background colour.
 *
 * Pixels are processed 8 at a time as float8 vectors (one AVX register on a
 * CPU), so PoCL runs 8 SIMD lanes per splat; a forward work-item renders one
 * 16-pixel tile row, and a splat whose box misses the row costs one test.
 */
#ifndef BLEND_NORMALIZED
#define BLEND_NORMALIZED 0
#endif
#ifndef EPS
#define EPS 1e-3f
#endif
#define TILE 16
#define VW 8            /* pixels per work-item */
#define CUTOFF_Q 9.0f   /* 3 sigma */
#define NGRAD 10        /* per entry: d/d(mx, my, A, B2, C, r, g, b, opacity), sum of w */

#define LANES ((float8)(0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f))

/* exp(-q / 2) as 2^n * p(f) with y = -q log2(e) / 2 = n + f, f in [0, 1), p a degree-5
 * fit of 2^f (relative error < 2e-7): the same on every driver, and it vectorises on
 * a CPU where the library exp costs several times more. */
inline float8 falloff(const float8 q)
{
    const float8 y = fmax(-0.72134752f * q, -126.0f);
    const float8 n = floor(y);
    const float8 f = y - n;
    float8 p = 0.00189510729f;
    p = p * f + 0.00894621467f;
    p = p * f + 0.0558632827f;
    p = p * f + 0.24014077f;
    p = p * f + 0.69315462f;
    p = p * f + 0.999999896f;
    return p * as_float8((convert_int8(n) + 127) << 23);
}

inline float hsum8(const float8 v)
{
    const float4 a = v.lo + v.hi;
    const float2 b = a.lo + a.hi;
    return b.x + b.y;
}

/* Blend one splat into 8 pixels of a row: (fx, fy) their centres, sums in (sr, sg, sb, sw). */
#define BLEND_INTO(fx, sr, sg, sb, sw)                                          \
    {                                                                           \
        const float8 dx = (fx) - s.s0;                                          \
        const float8 q = (s.s2 * dx + s.s3 * dy) * dx + cdy2;                   \
        const int8 inside = q < CUTOFF_Q;                                       \
        if (any(inside)) {                                                      \
            const float8 w = select((float8)(0.0f), s.s5 * falloff(q), inside); \
            sr += w * c.x;                                                      \
            sg += w * c.y;                                                      \
            sb += w * c.z;                                                      \
            sw += w;                                                            \
        }                                                                       \
    }

/* Work-item (row, n): the 16 pixels of row `row` of tile tiles[n], as two float8 halves.
 * out: 4 planes (I.rgb, sum of w). */
__kernel void splat_forward(__global const float8 *splats, __global const float4 *colors,
                            __global const int4 *bbox, __global const int *tile_start,
                            __global const int *tile_splats, __global const int *tiles,
                            const int tiles_x, const int plane, const float4 background,
                            __global float *out)
{
    const int row = get_global_id(0);
    const int t = tiles[get_global_id(1)];
    const int pitch = tiles_x * TILE;
    const int x0 = (t % tiles_x) * TILE, py = (t / tiles_x) * TILE + row;
    const float8 fx_lo = (float)x0 + 0.5f + LANES, fx_hi = fx_lo + 8.0f;
    const float fy = py + 0.5f;
    float8 r_lo = (float8)(0.0f), g_lo = r_lo, b_lo = r_lo, w_lo = r_lo;
    float8 r_hi = r_lo, g_hi = r_lo, b_hi = r_lo, w_hi = r_lo;
    const int end = tile_start[t + 1];
    for (int k = tile_start[t]; k < end; ++k) {
        const int i = tile_splats[k];
        const int4 box = bbox[i];
        const bool row_outside_box = py < box.y || py >= box.w;
        if (row_outside_box) continue;
        const float8 s = splats[i];
        const float4 c = colors[i];
        const float dy = fy - s.s1;
        const float cdy2 = s.s4 * dy * dy;
        if (box.x < x0 + VW) BLEND_INTO(fx_lo, r_lo, g_lo, b_lo, w_lo)
        if (box.z > x0 + VW) BLEND_INTO(fx_hi, r_hi, g_hi, b_hi, w_hi)
    }
#if BLEND_NORMALIZED
    const float8 n_lo = 1.0f / (w_lo + EPS), n_hi = 1.0f / (w_hi + EPS);
    r_lo = (r_lo + EPS * background.x) * n_lo;
    g_lo = (g_lo + EPS * background.y) * n_lo;
    b_lo = (b_lo + EPS * background.z) * n_lo;
    r_hi = (r_hi + EPS * background.x) * n_hi;
    g_hi = (g_hi + EPS * background.y) * n_hi;
    b_hi = (b_hi + EPS * background.z) * n_hi;
#else
    r_lo += background.x; g_lo += background.y; b_lo += background.z;
    r_hi += background.x; g_hi += background.y; b_hi += background.z;
#endif
    __global float *p = out + py * pitch + x0;
    vstore8(r_lo, 0, p);             vstore8(r_hi, 1, p);
    vstore8(g_lo, 0, p + plane);     vstore8(g_hi, 1, p + plane);
    vstore8(b_lo, 0, p + 2 * plane); vstore8(b_hi, 1, p + 2 * plane);
    vstore8(w_lo, 0, p + 3 * plane); vstore8(w_hi, 1, p + 3 * plane);
}

/* One work-item per (tile, splat) entry: the splat's gradient summed over the
 * pixels of that tile inside its 3-sigma box.  Entries never share an output
 * row, so there are no races; the host sums rows per splat.
 * dimg: 4 planes (g.rgb, k) such that dL/dc_i = g w_i and dL/dw_i = g . c_i - k
 * at each pixel (see gauss.py: pixel_adjoint); zero in the padding.
 * partial: NGRAD floats per entry. */
__kernel void splat_backward(__global const float8 *splats, __global const float4 *colors,
                             __global const int4 *bbox, __global const int *entry_splat,
                             __global const int *entry_tile, const int n_entries,
                             const int tiles_x, const int plane,
                             __global const float *dimg, __global float *partial)
{
    const int e = get_global_id(0);
    if (e >= n_entries) return;
    const int i = entry_splat[e], t = entry_tile[e];
    const int pitch = tiles_x * TILE;
    const float8 s = splats[i];
    const float3 c = colors[i].xyz;
    const int4 box = bbox[i];
    const int tx = (t % tiles_x) * TILE, ty = (t / tiles_x) * TILE;
    const int y0 = max(box.y, ty), y1 = min(box.w, ty + TILE);
    float8 gmx = (float8)(0.0f), gmy = gmx, gA = gmx, gB = gmx, gC = gmx;
    float8 gr = gmx, gg = gmx, gb = gmx, go = gmx, wsum = gmx;
    for (int x0 = tx; x0 < tx + TILE; x0 += VW) {
        const bool outside_box = x0 + VW <= box.x || x0 >= box.z;
        if (outside_box) continue;
        /* columns inside the splat's box, as a lane mask */
        const int8 lane = (int8)(0, 1, 2, 3, 4, 5, 6, 7) + x0;
        const int8 in_box = (lane >= box.x) & (lane < box.z);
        const float8 dx = (float)x0 + 0.5f + LANES - s.s0;
        for (int py = y0; py < y1; ++py) {
            const float dy = py + 0.5f - s.s1;
            const float8 q = (s.s2 * dx + s.s3 * dy) * dx + s.s4 * dy * dy;
            const int8 inside = (q < CUTOFF_Q) & in_box;
            if (!any(inside)) continue;
            const float8 g = select((float8)(0.0f), falloff(q), inside);
            const float8 w = s.s5 * g;
            __global const float *d = dimg + py * pitch + x0;
            const float8 d_r = vload8(0, d), d_g = vload8(0, d + plane), d_b = vload8(0, d + 2 * plane);
            const float8 dLdw = d_r * c.x + d_g * c.y + d_b * c.z - vload8(0, d + 3 * plane);
            const float8 dLdq = -0.5f * dLdw * w;
            gr += d_r * w;
            gg += d_g * w;
            gb += d_b * w;
            go += dLdw * g;
            gA += dLdq * dx * dx;
            gB += dLdq * dx * dy;
            gC += dLdq * dy * dy;
            /* dq/dm = -(dq/d(dx), dq/d(dy)) */
            gmx -= dLdq * (2.0f * s.s2 * dx + s.s3 * dy);
            gmy -= dLdq * (s.s3 * dx + 2.0f * s.s4 * dy);
            wsum += w;
        }
    }
    __global float *out = partial + (size_t)e * NGRAD;
    out[0] = hsum8(gmx); out[1] = hsum8(gmy);
    out[2] = hsum8(gA); out[3] = hsum8(gB); out[4] = hsum8(gC);
    out[5] = hsum8(gr); out[6] = hsum8(gg); out[7] = hsum8(gb);
    out[8] = hsum8(go); out[9] = hsum8(wsum);
}
