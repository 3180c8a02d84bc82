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
INLINE float2 sample_disk_concentric(float2 u) {
    float2 o = 2.0f * u - (float2)(1.0f);
    if (o.x == 0.0f && o.y == 0.0f) return (float2)(0.0f);
    float r, theta;
    if (fabs(o.x) > fabs(o.y)) {
        r = o.x; theta = (M_PI_F / 4.0f) * (o.y / o.x);
    } else {
        r = o.y; theta = M_PI_F / 2.0f - (M_PI_F / 4.0f) * (o.x / o.y);
    }
    float s, c;
    SINCOS(theta, s, c);
    return r * (float2)(c, s);
}

/* The primary ray through image point (sx, sy), each from -1 (left, bottom) to 1 (right, top).  A pinhole
 * perspective ray is make_ray(origin, unit(forward + sx right + sy up)), as it always was, and a pinhole
 * (aperture 0) draws no random numbers, so the images and random streams of pinhole renders are the ones
 * before lenses existed.  With a lens, two numbers of `rng` place the ray's start on the lens disc. */
INLINE Ray camera_ray(const Camera *c, float sx, float sy, Rng *rng) {
    float3 origin = vload3(0, c->origin), forward = vload3(0, c->forward);
    float3 right = vload3(0, c->right), up = vload3(0, c->up);
    float3 d; /* towards the image point, forward component 1: origin + f d lies on the plane in focus */
    if (c->projection == PROJECTION_ORTHOGRAPHIC) {
        origin = origin + sx * right + sy * up;
        d = forward;
    } else {
        d = forward + sx * right + sy * up;
    }
    if (!(c->aperture > 0.0f)) return make_ray(origin, unit(d));
    float2 lens = sample_disk_concentric(rng_next2(rng));
    float3 focus = origin + c->focus_distance * d;
    float3 start = origin + lens.x * vload3(0, c->lens_right) + lens.y * vload3(0, c->lens_up);
    return make_ray(start, unit(focus - start));
}

/* One sample of a pixel, as every integrator's pixel loop takes it: its place in the pixel, the pixel filter's weight
 * there, and the camera ray through it. */
typedef struct {
    Ray ray;
    float2 off;   /* in [0, 1)^2 from the pixel's corner (sampling.h pixel_sample_offset) */
    float weight; /* pixel_filter_weight at off */
} PixelSample;

/* Sample s of pixel `pixel` (its index in the frame, row-major) by pixel_sample_offset(sampler, s, n, rng). */
INLINE PixelSample pixel_sample(const FrameParams *frame, int pixel, int sampler, uint s, uint n, Rng *rng) {
    PixelSample ps;
    ps.off = pixel_sample_offset(sampler, s, n, rng);
    float px = (float)(pixel % frame->width), py = (float)(pixel / frame->width);
    float sx = 2.0f * (px + ps.off.x) / (float)frame->width - 1.0f;
    float sy = 1.0f - 2.0f * (py + ps.off.y) / (float)frame->height;
    ps.ray = camera_ray(&frame->camera, sx, sy, rng);
    ps.weight = pixel_filter_weight(frame->pixel_filter, ps.off);
    return ps;
}

#endif
