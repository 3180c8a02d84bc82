/* The watertight ray-triangle test, written once for one triangle (float) and for a leaf block of
 * BLOCK_LANES triangles (float4): kernels/intersect.h includes this file twice, with
 *   TRI_F   float or float4          TRI_I   int or int4 (what a comparison of TRI_F gives)
 *   TRI_ANY(m)  any lane of m set    TRI_ABS(x)  |x|     TRI_DOP, TRI_TEST  the functions' names
 *   TRI_R   the type of the ray's shear and t range: float, or float8 for a packet of rays in lanes
 *           (kernels/packet.h, where the lanes are rays and the triangle is the same in all of them)
 * All are the same float operations in the same order (and intersect.h turns FP_CONTRACT off), so a
 * block lane's t, u, v are bit for bit the one-triangle test's: the wide tree, the binary tree and
 * the BVH-off path agree exactly.  Comparisons are combined with & and |, and negated with == 0, so
 * the code reads the same for 0/1 scalar and 0/-1 vector truth values.  The TRI_ names are undefined at
 * the end, ready for the next inclusion. */

/* a*b - c*d with the sign of the exact value (barring underflow).  The plain difference has that
 * sign unless it is within its own rounding error, u (|ab| + |cd|); only then is it recomputed by
 * Kahan's algorithm (error at most 2u relative, Jeannerod, Louvet and Muller 2013), whose fma costs
 * a call on PoCL.  The triangle on the other side of a shared edge computes the same products in
 * the other order and gets exactly -e, so the two always put a ray on opposite sides of the edge
 * (or both on it): no ray passes between them. */
INLINE TRI_F TRI_DOP(TRI_F a, TRI_F b, TRI_F c, TRI_F d) {
    TRI_F ab = a * b, cd = c * d, e = ab - cd;
    TRI_I unsure = TRI_ABS(e) <= 2.38418579e-7f * (TRI_ABS(ab) + TRI_ABS(cd)); /* 2^-22: twice the bound */
    if (TRI_ANY(unsure)) {
        TRI_F exact = fma(a, b, -cd) + fma(-c, d, cd);
        e = unsure ? exact : e;
    }
    return e;
}

/* Woop, Benthin and Wald (JCGT 2013), as pbrt-v4's IntersectTriangle, two-sided.  q0..q2 are the
 * vertices minus the ray origin with their axes already permuted (x = the ray's kx, y = ky, z = kz:
 * the direction's largest axis); they are sheared so that the ray is +z, and the 2D edge functions
 * of the sheared vertices decide inside or outside.  Returns t in (t_min, t_max), INF_T on a miss
 * (and in lanes not `valid`), and the barycentrics u, v of v1, v2.  Hits whose t is within the test's
 * own error bound (pbrt's deltaT) are rejected, so t > 0 holds for every hit reported; for a grazing
 * ray (tiny det) that bound can exceed a real hit's t, which is then missed, as in pbrt-v4. */
INLINE TRI_F TRI_TEST(TRI_F p0x, TRI_F p0y, TRI_F p0z, TRI_F p1x, TRI_F p1y, TRI_F p1z, TRI_F p2x, TRI_F p2y,
                      TRI_F p2z, TRI_I valid, TRI_R sx, TRI_R sy, TRI_R sz, TRI_R t_min, TRI_R t_max, TRI_F *u,
                      TRI_F *v) {
    p0x += sx * p0z; p0y += sy * p0z;
    p1x += sx * p1z; p1y += sy * p1z;
    p2x += sx * p2z; p2y += sy * p2z;
    /* edge functions: which side of each edge the ray (the origin of the sheared plane) lies on */
    TRI_F e0 = TRI_DOP(p1x, p2y, p1y, p2x);
    TRI_F e1 = TRI_DOP(p2x, p0y, p2y, p0x);
    TRI_F e2 = TRI_DOP(p0x, p1y, p0y, p1x);
    TRI_I outside = ((e0 < 0.0f) | (e1 < 0.0f) | (e2 < 0.0f)) & ((e0 > 0.0f) | (e1 > 0.0f) | (e2 > 0.0f));
    TRI_F det = e0 + e1 + e2;
    TRI_I live = valid & (outside == 0) & (det != 0.0f); /* a miss, or the triangle met edge-on */
    if (!TRI_ANY(live)) return (TRI_F)(INF_T);
    /* scaled distance, compared with the range before the one division */
    p0z *= sz; p1z *= sz; p2z *= sz;
    TRI_F t_scaled = e0 * p0z + e1 * p1z + e2 * p2z;
    TRI_I beyond = ((det < 0.0f) & ((t_scaled >= t_min * det) | (t_scaled < t_max * det))) |
                   ((det > 0.0f) & ((t_scaled <= t_min * det) | (t_scaled > t_max * det)));
    live &= beyond == 0;
    if (!TRI_ANY(live)) return (TRI_F)(INF_T);
    TRI_F inv_det = 1.0f / det;
    TRI_F t = t_scaled * inv_det;
    /* reject t within the rounding error of the test itself (pbrt-v4's bound) */
    TRI_F a0z = TRI_ABS(p0z), a1z = TRI_ABS(p1z), a2z = TRI_ABS(p2z);
    TRI_F a0x = TRI_ABS(p0x), a1x = TRI_ABS(p1x), a2x = TRI_ABS(p2x);
    TRI_F a0y = TRI_ABS(p0y), a1y = TRI_ABS(p1y), a2y = TRI_ABS(p2y);
    TRI_F max_zt = a0z > a1z ? a0z : a1z; max_zt = max_zt > a2z ? max_zt : a2z;
    TRI_F max_xt = a0x > a1x ? a0x : a1x; max_xt = max_xt > a2x ? max_xt : a2x;
    TRI_F max_yt = a0y > a1y ? a0y : a1y; max_yt = max_yt > a2y ? max_yt : a2y;
    TRI_F delta_z = GAMMA(3) * max_zt;
    TRI_F delta_x = GAMMA(5) * (max_xt + max_zt), delta_y = GAMMA(5) * (max_yt + max_zt);
    TRI_F delta_e = 2.0f * (GAMMA(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    TRI_F ae0 = TRI_ABS(e0), ae1 = TRI_ABS(e1), ae2 = TRI_ABS(e2);
    TRI_F max_e = ae0 > ae1 ? ae0 : ae1; max_e = max_e > ae2 ? max_e : ae2;
    TRI_F delta_t = 3.0f * (GAMMA(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * TRI_ABS(inv_det);
    TRI_F t_lower = delta_t > t_min ? delta_t : (TRI_F)(t_min);
    live &= (t > t_lower) & (t < t_max);
    *u = e1 * inv_det;
    *v = e2 * inv_det;
    return live ? t : (TRI_F)(INF_T);
}

#undef TRI_F
#undef TRI_I
#undef TRI_ANY
#undef TRI_ABS
#undef TRI_DOP
#undef TRI_TEST
#undef TRI_R
