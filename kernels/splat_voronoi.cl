/* Nearest-site (Voronoi) splatting: hard nearest site per pixel, and a soft
 * (softmax over the K nearest sites) model with gradients.
 *
 * Conventions (packed by clrender/splat/voronoi.py):
 *   pixel (x, y) has its centre at (x + 0.5, y + 0.5), in pixel units;
 *   sites     float2 per site, pixel units, any finite value;
 *   grid      square cells of side `cell` = a power of two (so x / cell, floor and
 *             the cell borders are exact in float32), gw x gh cells covering
 *             [0, gw cell) x [0, gh cell) which holds the image; a site outside
 *             is binned into the nearest border cell;
 *   sorted_pos / sorted_idx  the sites in cell order (counting sort on the host),
 *             cell c holds entries [cell_start[c], cell_start[c + 1]).
 *
 * Distances are squared, computed as dx*dx + dy*dy with contraction off, in the
 * same order in every kernel (and in the numpy reference), and ties go to the
 * lower site index: so `nearest_naive` and `nearest_grid` agree exactly.
 */
#pragma OPENCL FP_CONTRACT OFF

/* VORONOI_STRIP: pixels per work-item of the grid kernel */
#include "layout.h"

#ifndef K
#define K 8                  /* soft model: sites blended per pixel */
#endif

inline float site_d2(float px, float py, float2 s)
{
    float dx = px - s.x;
    float dy = py - s.y;
    return dx * dx + dy * dy;
}

/* (d2, index) ordered lexicographically: the lower index wins a tie. */
inline int is_closer(float d2, int i, float best_d2, int best_i)
{
    return d2 < best_d2 || (d2 == best_d2 && i < best_i);
}

/* Every site for every pixel: the brute-force baseline. */
__kernel void nearest_naive(__global const float2 *sites, int n, int width, int height,
                            __global int *nearest)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= height)
        return;
    float px = x + 0.5f, py = y + 0.5f;
    float best_d2 = INFINITY;
    int best_i = 0;
    for (int i = 0; i < n; ++i) {
        float d2 = site_d2(px, py, sites[i]);
        if (d2 < best_d2) {          /* ascending i: strict < keeps the lower index */
            best_d2 = d2;
            best_i = i;
        }
    }
    nearest[y * width + x] = best_i;
}

/* Lower bound on the distance from p to any site binned outside the block of
 * cells within Chebyshev distance r - 1 of p's cell (cx, cy): the distance to
 * the block's nearest side.  Exact in float32 because CELL is a power of two;
 * since rounding is monotone, such a site's computed d2 is >= gap * gap. */
inline float ring_gap(float px, float py, int cx, int cy, int r, float cell)
{
    float lo_x = px - (float)(cx - r + 1) * cell, hi_x = (float)(cx + r) * cell - px;
    float lo_y = py - (float)(cy - r + 1) * cell, hi_y = (float)(cy + r) * cell - py;
    return fmax(fmin(fmin(lo_x, hi_x), fmin(lo_y, hi_y)), 0.0f);
}

/* Exact nearest site through the uniform grid.  One work-item handles a strip
 * of 8 horizontally adjacent pixels as one float8, so every site is tested
 * against 8 pixels at once (explicit SIMD, which also keeps the loops uniform
 * within a work-item).  Rings of cells are scanned outward around the strip's
 * cells until no site outside the scanned block can be closer to any of the
 * 8 pixels, or the ring has left the grid on every side.  Each pixel's result
 * is the same as a per-pixel search: the same d2 arithmetic, ties by index. */
__kernel void nearest_grid(__global const float2 *sorted_pos, __global const int *sorted_idx,
                           __global const int *cell_start, int gw, int gh, float cell, int width, int height,
                           __global int *nearest)
{
    int x0 = get_global_id(0) * VORONOI_STRIP, y = get_global_id(1);
    if (x0 >= width || y >= height)
        return;
    /* lanes past the right edge repeat the last pixel; they are not stored */
    int8 lane_x = min((int8)(x0) + (int8)(0, 1, 2, 3, 4, 5, 6, 7), (int8)(width - 1));
    float8 px = convert_float8(lane_x) + 0.5f;
    float py = y + 0.5f;
    float inv_cell = 1.0f / cell;        /* exact: cell is a power of two */
    int cxa = min((int)(px.s0 * inv_cell), gw - 1);
    int cxb = min((int)(px.s7 * inv_cell), gw - 1);
    int cy = min((int)(py * inv_cell), gh - 1);
    int last_ring = max(max(cxa, gw - 1 - cxb), max(cy, gh - 1 - cy));
    float8 best_d2 = (float8)(INFINITY);
    int8 best_i = (int8)(INT_MAX);
    for (int r = 0; r <= last_ring; ++r) {
        if (r > 0) {
            /* distance of each pixel to the side of the block scanned so far */
            float8 gap = fmin(fmin(px - (float)(cxa - r + 1) * cell, (float)(cxb + r) * cell - px),
                              (float8)(fmin(py - (float)(cy - r + 1) * cell, (float)(cy + r) * cell - py)));
            gap = fmax(gap, 0.0f);
            if (all(gap * gap > best_d2))
                break;               /* every unscanned site is strictly farther, for all 8 */
        }
        int y0 = max(cy - r, 0), y1 = min(cy + r, gh - 1);
        int xa = max(cxa - r, 0), xb = min(cxb + r, gw - 1);
        for (int gy = y0; gy <= y1; ++gy) {
            /* the ring's cells in this row as at most two runs of consecutive
             * cells, each one contiguous range of the cell-sorted sites */
            int full_row = gy == cy - r || gy == cy + r;
            int row = gy * gw;
            int a1 = full_row ? xb : min(cxa - r, xb);           /* whole row, or the left cell */
            int b0 = max(cxb + r, xa), b1 = full_row ? -1 : xb;  /* the right cell of an inner row */
            for (int run = 0; run < 2; ++run) {
                int lo = run ? b0 : xa, hi = run ? b1 : a1;
                if (hi < lo)
                    continue;
                int e1 = cell_start[row + hi + 1];
                for (int e = cell_start[row + lo]; e < e1; ++e) {
                    float2 s = sorted_pos[e];
                    int i = sorted_idx[e];
                    float8 dx = px - s.x;
                    float dy = py - s.y;
                    float8 d2 = dx * dx + (float8)(dy * dy);   /* = site_d2 per lane */
                    int8 closer = (d2 < best_d2) | ((d2 == best_d2) & ((int8)(i) < best_i));
                    best_d2 = select(best_d2, d2, closer);
                    best_i = select(best_i, (int8)(i), closer);
                }
            }
        }
    }
    if (x0 + VORONOI_STRIP <= width) {
        vstore8(best_i, 0, nearest + y * width + x0);
    } else {
        int out[8];
        vstore8(best_i, 0, out);
        for (int k = 0; x0 + k < width; ++k)
            nearest[y * width + x0 + k] = out[k];
    }
}

/* Soft model, forward: the K nearest sites of each pixel (grid search as
 * above, keeping a sorted list), weights w_j = softmax_j(-d2_j / T) and the
 * blend out = sum_j w_j c_j.  Writes idx/w (K per pixel) for the backward pass. */
__kernel void soft_forward(__global const float2 *sorted_pos, __global const int *sorted_idx,
                           __global const int *cell_start, int2 grid_cells, float cell, int width, int height,
                           __global const float4 *colors, float inv_temp,
                           __global int *knn_idx, __global float *knn_w, __global float4 *out)
{
    int gw = grid_cells.x, gh = grid_cells.y;  /* the grid's gw x gh cells */
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= height)
        return;
    float px = x + 0.5f, py = y + 0.5f;
    float inv_cell = 1.0f / cell;        /* exact: cell is a power of two */
    int cx = min((int)(px * inv_cell), gw - 1);
    int cy = min((int)(py * inv_cell), gh - 1);
    int last_ring = max(max(cx, gw - 1 - cx), max(cy, gh - 1 - cy));
    float bd[K];
    int bi[K];
    for (int j = 0; j < K; ++j) {
        bd[j] = INFINITY;
        bi[j] = INT_MAX;
    }
    for (int r = 0; r <= last_ring; ++r) {
        float gap = ring_gap(px, py, cx, cy, r, cell);
        if (r > 0 && gap * gap > bd[K - 1])
            break;                   /* the K-th best cannot be displaced any more */
        int y0 = max(cy - r, 0), y1 = min(cy + r, gh - 1);
        for (int gy = y0; gy <= y1; ++gy) {
            int full_row = gy == cy - r || gy == cy + r;
            int step = full_row ? 1 : 2 * r;
            for (int gx = cx - r; gx <= cx + r; gx += step) {
                if (gx < 0 || gx >= gw)
                    continue;
                int c = gy * gw + gx;
                for (int e = cell_start[c]; e < cell_start[c + 1]; ++e) {
                    float d2 = site_d2(px, py, sorted_pos[e]);
                    int i = sorted_idx[e];
                    if (!is_closer(d2, i, bd[K - 1], bi[K - 1]))
                        continue;
                    /* insertion into the sorted list, dropping the last */
                    int j = K - 1;
                    while (j > 0 && is_closer(d2, i, bd[j - 1], bi[j - 1])) {
                        bd[j] = bd[j - 1];
                        bi[j] = bi[j - 1];
                        --j;
                    }
                    bd[j] = d2;
                    bi[j] = i;
                }
            }
        }
    }
    /* softmax, shifted by the nearest distance for range */
    float total = 0.0f;
    float w[K];
    for (int j = 0; j < K; ++j) {
        w[j] = exp(-(bd[j] - bd[0]) * inv_temp);
        total += w[j];
    }
    float4 blend = (float4)(0.0f);
    int p = y * width + x;
    for (int j = 0; j < K; ++j) {
        w[j] /= total;
        blend += w[j] * colors[bi[j]];
        knn_idx[p * K + j] = bi[j];
        knn_w[p * K + j] = w[j];
    }
    out[p] = blend;
}

/* Soft model, backward: given g = dL/dout per pixel, the gradient of each
 * (pixel, neighbour j) pair with respect to that site's position:
 *   dL/ds_j += (g . (c_j - out)) w_j 2 (p - s_j) / T.
 * Pairs are written out (no atomics) and summed per site on the host. */
__kernel void soft_backward(__global const float2 *sites, __global const float4 *colors,
                            __global const int *knn_idx, __global const float *knn_w,
                            __global const float4 *out, __global const float4 *grad_out,
                            float inv_temp, int width, int height, __global float2 *grad_pos)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= height)
        return;
    int p = y * width + x;
    float2 pc = (float2)(x + 0.5f, y + 0.5f);
    float4 g = grad_out[p], o = out[p];
    for (int j = 0; j < K; ++j) {
        int i = knn_idx[p * K + j];
        float q = dot(g, colors[i] - o) * knn_w[p * K + j] * 2.0f * inv_temp;
        grad_pos[p * K + j] = q * (pc - sites[i]);
    }
}
