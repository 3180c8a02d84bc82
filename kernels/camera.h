/* The camera's primary rays and a pixel's samples, one function each for every integrator (trace.cl's render,
 * path.cl's render_path and the wavefront).  The Camera record (clrender/layout.py, packed by clrender/scene/camera.py) holds a
 * perspective or orthographic frame and a thin lens: a lens of radius `aperture` whose rays through one
 * image point all meet where that point's pinhole ray crosses the plane `focus_distance` ahead, so that
 * plane is sharp and a point at distance d is a disc of diameter 2 aperture |d - focus| / (focus d) on
 * the perspective image plane at unit distance (pbrt-v4's PerspectiveCamera and OrthographicCamera). */
#ifndef CLRENDER_CAMERA_H
#define CLRENDER_CAMERA_H

#include "common.h"
#include "rng.h"
#include "mathf.h"
#include "sampling.h"

/* A uniform point of the unit disc from u in [0,1)^2, by Shirley and Chiu's concentric map (pbrt-v4's
 * SampleUniformDiskConcentric): squares to rings, so stratified u stay stratified on the lens. */
INLINE V2 sample_disk_concentric(V2 u) {
    LF ox = 2.0f * u.x - 1.0f, oy = 2.0f * u.y - 1.0f;
    LI wide = fabs(ox) > fabs(oy);
    LF r = wide ? ox : oy;
    LF theta = wide ? (M_PI_F / 4.0f) * (oy / ox) : M_PI_F / 2.0f - (M_PI_F / 4.0f) * (ox / oy);
    LF s, c;
    sincos_l(theta, &s, &c);
    LI centre = (ox == 0.0f) & (oy == 0.0f);
    return v2(centre ? (LF)(0.0f) : r * c, centre ? (LF)(0.0f) : r * s);
}

/* The primary ray through image point (sx, sy), each from -1 (left, bottom) to 1 (right, top): its origin in *o and
 * its unit direction.  A pinhole perspective ray is (origin, unit(forward + sx right + sy up)), as it always was,
 * and a pinhole (aperture 0) draws no random numbers, so the images and random streams of pinhole renders are the
 * ones before lenses existed.  With a lens, two numbers of `rng` place the ray's start on the lens disc. */
INLINE V3 camera_ray(const Camera *c, LF sx, LF sy, Rng *rng, V3 *o) {
    float3 origin = vload3(0, c->origin), forward = vload3(0, c->forward);
    float3 right = vload3(0, c->right), up = vload3(0, c->up);
    V3 start = splat3(origin), d; /* towards the image point, forward component 1: origin + f d lies on the plane in focus */
    if (c->projection == PROJECTION_ORTHOGRAPHIC) {
        start = v3(origin.x + sx * right.x + sy * up.x, origin.y + sx * right.y + sy * up.y, origin.z + sx * right.z + sy * up.z);
        d = splat3(forward);
    } else {
        d = v3(forward.x + sx * right.x + sy * up.x, forward.y + sx * right.y + sy * up.y, forward.z + sx * right.z + sy * up.z);
    }
    if (!(c->aperture > 0.0f)) {
        *o = start;
        return vunit(d);
    }
    V2 lens = sample_disk_concentric(rng_next2(rng));
    float f = c->focus_distance;
    V3 focus = v3(start.x + f * d.x, start.y + f * d.y, start.z + f * d.z);
    float3 lr = vload3(0, c->lens_right), lu = vload3(0, c->lens_up);
    *o = v3(start.x + lens.x * lr.x + lens.y * lu.x, start.y + lens.x * lr.y + lens.y * lu.y, start.z + lens.x * lr.z + lens.y * lu.z);
    return vunit(vsub(focus, *o));
}

/* One sample of a pixel, as every integrator's pixel loop takes it: its place in the pixel, the pixel filter's weight
 * there, and the camera ray through it (origin o, unit direction d). */
typedef struct {
    V3 o, d;
    V2 off;    /* in [0, 1)^2 from the pixel's corner (sampling.h pixel_sample_offset) */
    LF weight; /* pixel_filter_weight at off */
} PixelSample;

/* Sample s of pixel `pixel` (its index in the frame, row-major) by pixel_sample_offset(sampler, s, n, rng). */
INLINE PixelSample pixel_sample(const FrameParams *frame, LI pixel, int sampler, LU s, uint n, Rng *rng) {
    PixelSample ps;
    ps.off = pixel_sample_offset(sampler, s, n, rng);
    LF px = CONVERT_F(pixel % frame->width), py = CONVERT_F(pixel / frame->width);
    LF sx = 2.0f * (px + ps.off.x) / (float)frame->width - 1.0f;
    LF sy = 1.0f - 2.0f * (py + ps.off.y) / (float)frame->height;
    ps.d = camera_ray(&frame->camera, sx, sy, rng, &ps.o);
    ps.weight = pixel_filter_weight(frame->pixel_filter, ps.off);
    return ps;
}

#endif
