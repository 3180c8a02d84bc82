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
 *   tiles      int per work-group row: which tile that row renders.
 * Pixel (px, py) has its centre at (px + 0.5, py + 0.5).
 *
 * Weight of splat i at a pixel: w_i = o_i exp(-q_i / 2) where q_i < 9, else 0.
 * BLEND_NORMALIZED 0 ("sum"):       I = bg + sum_i w_i c_i
 * BLEND_NORMALIZED 1 ("normalized"): I = (sum_i w_i c_i + EPS bg) / (sum_i w_i + EPS)
 * so where no splat reaches, a normalized pixel fades to the background colour.
 */
#ifndef BLEND_NORMALIZED
#define BLEND_NORMALIZED 0
#endif
#ifndef EPS
#define EPS 1e-3f
#endif
#define TILE 16
#define CUTOFF_Q 9.0f   /* 3 sigma */
#define NGRAD 10        /* per entry: d/d(mx, my, A, B2, C, r, g, b, opacity), sum of w */

/* One work-item per pixel, one 16x16 work-group row per tile in `tiles`.
 * out: float4 per pixel (I.rgb, sum of w). */
__kernel void splat_forward(__global const float8 *splats, __global const float4 *colors,
                            __global const int *tile_start, __global const int *tile_splats,
                            __global const int *tiles, const int width, const int height,
                            const int tiles_x, const float4 background, __global float4 *out)
{
    const int lid = get_global_id(0);
    const int t = tiles[get_global_id(1)];
    const int px = (t % tiles_x) * TILE + lid % TILE;
    const int py = (t / tiles_x) * TILE + lid / TILE;
    const float fx = px + 0.5f, fy = py + 0.5f;
    float4 acc = (float4)(0.0f);  /* (sum w c, sum w) */
    const int end = tile_start[t + 1];
    for (int k = tile_start[t]; k < end; ++k) {
        const int i = tile_splats[k];
        const float8 s = splats[i];
        const float dx = fx - s.s0, dy = fy - s.s1;
        const float q = s.s2 * dx * dx + s.s3 * dx * dy + s.s4 * dy * dy;
        if (q < CUTOFF_Q) {
            const float w = s.s5 * exp(-0.5f * q);
            const float4 c = colors[i];
            acc += w * (float4)(c.x, c.y, c.z, 1.0f);
        }
    }
    if (px >= width || py >= height) return;
#if BLEND_NORMALIZED
    const float3 rgb = (acc.xyz + EPS * background.xyz) / (acc.w + EPS);
#else
    const float3 rgb = acc.xyz + background.xyz;
#endif
    out[py * width + px] = (float4)(rgb, acc.w);
}

/* One work-item per (tile, splat) entry: the splat's gradient summed over the
 * pixels of that tile inside its 3-sigma box.  Entries never share an output
 * row, so there are no races; the host sums rows per splat.
 * dimg: float4 per pixel (g.rgb, k) such that dL/dc_i = g w_i and
 * dL/dw_i = dot(g, c_i) - k at that pixel (see gauss.py: pixel_adjoint).
 * partial: NGRAD floats per entry. */
__kernel void splat_backward(__global const float8 *splats, __global const float4 *colors,
                             __global const int4 *bbox, __global const int *entry_splat,
                             __global const int *entry_tile, const int n_entries,
                             const int width, const int tiles_x,
                             __global const float4 *dimg, __global float *partial)
{
    const int e = get_global_id(0);
    if (e >= n_entries) return;
    const int i = entry_splat[e], t = entry_tile[e];
    const float8 s = splats[i];
    const float3 c = colors[i].xyz;
    const int4 b = bbox[i];
    /* the part of the splat's box inside this tile */
    const int x0 = max(b.x, (t % tiles_x) * TILE), x1 = min(b.z, (t % tiles_x) * TILE + TILE);
    const int y0 = max(b.y, (t / tiles_x) * TILE), y1 = min(b.w, (t / tiles_x) * TILE + TILE);
    float gmx = 0.0f, gmy = 0.0f, gA = 0.0f, gB = 0.0f, gC = 0.0f, go = 0.0f, wsum = 0.0f;
    float3 gc = (float3)(0.0f);
    for (int py = y0; py < y1; ++py) {
        const float dy = py + 0.5f - s.s1;
        for (int px = x0; px < x1; ++px) {
            const float dx = px + 0.5f - s.s0;
            const float q = s.s2 * dx * dx + s.s3 * dx * dy + s.s4 * dy * dy;
            if (q < CUTOFF_Q) {
                const float g = exp(-0.5f * q);
                const float w = s.s5 * g;
                const float4 d = dimg[py * width + px];
                const float dLdw = dot(d.xyz, c) - d.w;
                const float dLdq = -0.5f * dLdw * w;
                gc += d.xyz * w;
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
    }
    __global float *row = partial + (size_t)e * NGRAD;
    row[0] = gmx; row[1] = gmy; row[2] = gA; row[3] = gB; row[4] = gC;
    row[5] = gc.x; row[6] = gc.y; row[7] = gc.z; row[8] = go; row[9] = wsum;
}
