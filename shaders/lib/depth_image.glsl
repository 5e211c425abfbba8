// Ray / depth-image intersection: the lecture's two algorithms and the hierarchical traversal,
// shared by the mirror pass and the GPU ray query. depthimpostor/oracles/reference.py implements the
// lecture's two with the same function names; the hierarchical one finds the optimized one's hit.
// The marches take the texture of depth layers they read as an argument (`layers`): the mirror's
// depth images are in u_impostor_depth, with back colours in u_impostor_back_color; the lights'
// shadow maps (lib/shadows.glsl) are in another, without (`back_colors` false).
#ifndef ALGORITHM
#define ALGORITHM ALGORITHM_OPTIMIZED
#endif
#include "baked_images.glsl"
#include "solid_run.glsl"

// (visible surface, back of its solid run) at an atlas texel.
vec2 layers_at(sampler2D layers, ivec2 texel) {
    return solid_run(texelFetch(layers, texel, 0).rg);
}

// One Liang-Barsky step: keep the part of the ray where value + rate * t >= 0.
void clip_half_space(float value, float rate, inout float t_enter, inout float t_exit, inout bool inside) {
    if (rate == 0.0) {
        if (value < 0.0) inside = false;
    } else if (rate > 0.0) {
        t_enter = max(t_enter, -value / rate);
    } else {
        t_exit = min(t_exit, -value / rate);
    }
}

// Clip origin + t * direction (0 <= t <= t_limit) to the frustum, in camera coordinates (x, y, w) where every
// frustum plane is linear: no perspective divide happens before w >= w_near is guaranteed, so a
// ray that starts behind the eye or crosses its plane is clipped, not mirrored through it.
bool clip_ray(DepthImage image, vec3 p0, vec3 dp, float t_limit, out float t_enter, out float t_exit) {
    float width = image.depth_range.z, height = image.depth_range.w;
    // A zero direction is no ray: every rate below is 0, nothing would lower t_exit, and the
    // "clipped" ray would be the point p0 stretched to t = 3e38 (NaN in the float64 reference).
    bool inside = dp != vec3(0.0);
    t_enter = 0.0;
    t_exit = t_limit;  // UNBOUNDED_RAY: the frustum is bounded, so some plane always lowers this
    // Grown by CLIP_TOLERANCE_PIXELS: u >= -g is x + g w >= 0, and so on (see constants.py).
    float g = CLIP_TOLERANCE_PIXELS, depth_growth = g / max(width, height);
    clip_half_space(p0.z - image.depth_range.x * (1.0 - depth_growth), dp.z, t_enter, t_exit, inside);
    clip_half_space(image.depth_range.y * (1.0 + depth_growth) - p0.z, -dp.z, t_enter, t_exit, inside);
    clip_half_space(p0.x + g * p0.z, dp.x + g * dp.z, t_enter, t_exit, inside);
    clip_half_space((width + g) * p0.z - p0.x, (width + g) * dp.z - dp.x, t_enter, t_exit, inside);
    clip_half_space(p0.y + g * p0.z, dp.y + g * dp.z, t_enter, t_exit, inside);
    clip_half_space((height + g) * p0.z - p0.y, (height + g) * dp.z - dp.y, t_enter, t_exit, inside);
    return inside && t_enter <= t_exit;
}

// The ray parameter of screen parameter sigma along the projected segment a'b'. 1/w, not w, is
// affine in screen space: 1/w(sigma) = (1 - sigma)/w_a + sigma/w_b, which gives the 3-D parameter
// lambda = sigma w_a / ((1 - sigma) w_b + sigma w_a); both w are >= w_near > 0 after clipping.
float ray_parameter(float sigma, float w_a, float w_b, float t_enter, float t_exit) {
    float lambda = sigma * w_a / ((1.0 - sigma) * w_b + sigma * w_a);
    return t_enter + lambda * (t_exit - t_enter);
}

// A ray clipped to the frustum: its parameter range, the camera coordinates (x, y, w) of its ends,
// and their projections a' and b' as (u, v, OpenGL depth).
struct ClippedRay {
    float t_enter;
    float t_exit;
    vec3 pa;
    vec3 pb;
    vec3 sa;
    vec3 sb;
};

bool clip_and_project(DepthImage image, vec3 origin, vec3 direction, float t_limit, out ClippedRay ray) {
    vec3 p0 = camera_coordinates(image, origin - image.eye.xyz);
    vec3 dp = camera_coordinates(image, direction);
    if (!clip_ray(image, p0, dp, t_limit, ray.t_enter, ray.t_exit)) return false;
    ray.pa = p0 + dp * ray.t_enter;
    ray.pb = p0 + dp * ray.t_exit;
    ray.sa = vec3(ray.pa.xy / ray.pa.z, opengl_depth(image, ray.pa.z));
    ray.sb = vec3(ray.pb.xy / ray.pb.z, opengl_depth(image, ray.pb.z));
    return true;
}

// Do the 2-D segments [(0, ray0), (1, ray1)] and [(0, surface0), (1, surface1)] cross with the ray
// going from in front of the surface to behind it? f = ray depth - surface depth; k in [0, 1] is
// where along the step. Both depths are rounded float32 values, so "on the surface" is a band of
// CONTACT_DEPTH_TOLERANCE: without it, a ray lying in a surface sees the sign of f flip at random
// and its first crossing lands anywhere along it. A ray touching the surface inside the band
// hits at the end of the step nearest to it (k clamped), so k never leaves [0, 1].
bool segments_cross(float f0, float f1, out float k) {
    k = f0 == f1 ? 0.0 : clamp(f0 / (f0 - f1), 0.0, 1.0);
    return f0 <= CONTACT_DEPTH_TOLERANCE && f1 >= -CONTACT_DEPTH_TOLERANCE;
}

// Are two neighbouring samples one surface? Background (nothing rasterized) ends a surface, and
// a jump in depth steeper than MAX_SURFACE_SLOPE is a silhouette in front of something farther:
// the segment joining the two would be a "rubber sheet" over empty space, which a ray passing
// behind the silhouette would hit.
// The marches pass the samples' texels (texel_of), which they have already computed.
// A step in depth between two samples as a share of the steepest that joins them: 1/w is affine
// in OpenGL depth (surface.y - z * surface.z), and |w1 - w0| / min(w0, w1) = |1/w0 - 1/w1| /
// min(1/w0, 1/w1). Multiplied out, not divided: two samples of one texel (0 texels apart) give
// 0 <= 0 for equal depths, as they should.
bool depth_step_within(DepthImage image, ivec2 texel0, ivec2 texel1, float z0, float z1, float share) {
    float texels = length(vec2(texel1 - texel0));
    float inverse_w0 = image.surface.y - z0 * image.surface.z;
    float inverse_w1 = image.surface.y - z1 * image.surface.z;
    return abs(inverse_w1 - inverse_w0) <= share * image.surface.x * texels * min(inverse_w0, inverse_w1);
}

bool samples_connected(DepthImage image, ivec2 texel0, ivec2 texel1, float z0, float z1) {
    if (z0 >= BACKGROUND_DEPTH || z1 >= BACKGROUND_DEPTH) return false;
    return depth_step_within(image, texel0, texel1, z0, z1, 1.0);
}

// The number of steps: one per pixel along the projection's major axis, at most what the image
// can hold, and at least one. A ray through the eye projects to a point: ceil() gives 0 steps and
// the march would read nothing and miss; one step from a' to b' (one texel) compares the ray's
// depth at both ends with that texel's, which is the exact intersection with the surface there.
int step_count(DepthImage image, vec3 sa, vec3 sb) {
    float pixels = ceil(max(abs(sb.x - sa.x), abs(sb.y - sa.y)));
    return clamp(int(pixels), 1, int(max(image.depth_range.z, image.depth_range.w)) + 1);
}

// Is the ray, at OpenGL depth r, inside the object's first solid run at this sample (between
// the visible surface and the back face behind it, touching included)?
bool inside_solid(float r, vec2 layers) {
    return layers.x < BACKGROUND_DEPTH && r >= layers.x - CONTACT_DEPTH_TOLERANCE
        && r <= layers.y + CONTACT_DEPTH_TOLERANCE;
}

// A hit without its colour: the mirror's search reads it once, for the nearest hit over all its
// depth images (a shadow ray needs none), from `texel`, a sample the march read and found
// surface at. (Not the texel under s: between two diagonal samples s can lie over a third,
// background texel, whose cleared colour is white.)
RayHit hit_at(DepthImage image, float t, vec2 s, int samples, ivec2 texel, int layer) {
    RayHit hit = make_hit(true, t, s, vec3(0.0), image.eye.w, samples);
    hit.texel = texel;
    hit.layer = layer;
    return hit;
}

// Does a step come in through the back layer: from behind the nearest back face (f0 = back - r
// <= tolerance) to in front of it (f1 >= -tolerance), between two samples of one back surface
// whose colour the back layer's pass drew? A face turned away from the image's eye is seen by a
// ray that comes from behind it (a box's far side seen in a large mirror): without this the ray
// would only find itself inside the solid run a step later, at a hidden entry of unknown colour.
bool back_crossing(DepthImage image, ivec2 texel0, ivec2 texel1, float r0, float r1, vec2 z0, vec2 z1, out float k) {
    k = 1.0;
    // solid_run() gives back = front where no back face was drawn (an open surface).
    if (!(z0.y > z0.x && z1.y > z1.x) || !samples_connected(image, texel0, texel1, z0.y, z1.y)
        || !segments_cross(z0.y - r0, z1.y - r1, k)) return false;
    return texelFetch(u_impostor_back_color, k < 0.5 ? texel0 : texel1, 0).a > 0.0;
}

RayHit with_unseen(RayHit hit, float unseen_t, int unseen) {
    hit.unseen_t = unseen_t;
    hit.unseen = unseen;
    return hit;
}

// ------------------------------------------------------------------ What the image does not hold
// Per sample, a depth image holds the visible surface and the back of its first solid run: in
// front of the surface is seen empty space, the run is solid, and what lies behind the run, or
// between two samples across a silhouette, is not held at all. An answer (a hit, or a miss) is
// certain when the ray reached it through seen empty space alone, and a hit is on a surface the
// image holds (the visible one, or the back layer). The marches record the first place where that
// fails (constants.py's Unseen): UNSEEN_HIDDEN_ENTRY, the ray is inside a solid run without
// having crossed either (it came in through a side the image holds nothing of); UNSEEN_OCCLUDED,
// the ray is behind a solid run and at or behind where a second one begins (u_impostor_beyond;
// between the two, space is seen empty); UNSEEN_SILHOUETTE, a step within a texel of samples that
// are not one surface (texel_block: the texels whose centres are within a texel of either
// sample, since an edge between centres may pass anywhere between them), with the ray no farther
// in front of the nearest (or behind the farthest back face) than SILHOUETTE_BAND_TEXELS of the
// steepest slope two samples are joined across (a surface may reach that far between them); a
// step in front of the join of one surface and behind the extension of a join beside it (an edge
// the samples step over: crease_unseen); a hit on a join steeper than STEEP_JOIN_SHARE of the
// steepest, or within a texel of samples that are not one surface (hit_unseen). The
// record is the ray parameter of the step's start (the ray left seen space somewhere after it)
// and the kind. Only the variants that act on it track it (TRACK_UNSEEN: the hybrid method and the
// ray query); the reference (depthimpostor/oracles/reference.py) has the same functions.

#ifdef TRACK_UNSEEN
// Where a second solid run begins behind the first (methods/baked_images.py, beyond_run.frag): up to
// there the space behind the first run is seen empty too. 0 where that is not known.
uniform sampler2D u_impostor_beyond;
#endif

// Is the ray, at OpenGL depth r, behind the solid run at this sample?
bool behind_solid(float r, vec2 layers) {
    return layers.x < BACKGROUND_DEPTH && r > layers.y + CONTACT_DEPTH_TOLERANCE;
}

// Is the ray, at OpenGL depth r, in space the object hides from the eye at this sample: behind
// the first solid run, and at or behind where a second one begins?
bool occluded(ivec2 texel, float r, vec2 layers) {
#ifdef TRACK_UNSEEN
    return behind_solid(r, layers) && r >= texelFetch(u_impostor_beyond, texel, 0).r - CONTACT_DEPTH_TOLERANCE;
#else
    return behind_solid(r, layers);
#endif
}

// The OpenGL depth a ray must stay in front of (side 1) or behind (side -1) to be clear of a
// silhouette at a sample of depth z: 1/w larger (smaller) than the sample's by
// SILHOUETTE_BAND_TEXELS texels of the steepest joined slope (surface.x is its relative change in w
// per texel; 1/w = surface.y - depth surface.z).
float silhouette_clear_depth(DepthImage image, float z, float side) {
    float inverse_w = image.surface.y - z * image.surface.z;
    return (image.surface.y - inverse_w * (1.0 + side * SILHOUETTE_BAND_TEXELS * image.surface.x)) / image.surface.z;
}

// What the samples within one texel of image point s hold: the texels whose centres lie within one
// texel of s in u and in v (the 2 x 2 block a bilinear lookup reads). A sample stands for its
// texel's centre alone: a silhouette between two of these centres (an object's edge against the
// background, or a nearer surface against a farther one) may pass anywhere between them, and so
// reach s, although the sample the march reads at s shows no edge (a corner thinner than a texel
// covers no centre). `nearest`: the nearest visible surface; `farthest_back`: the farthest back of
// a solid run (0 where none is covered); `one_surface`: all four covered and joined, edge by edge.
struct TexelBlock {
    float nearest;
    float farthest_back;
    bool one_surface;
};

// The texel `offset` from `texel`, clamped to the image (as texel_of clamps).
ivec2 texel_beside(DepthImage image, ivec2 texel, ivec2 offset) {
    return image.tile.xy + clamp(texel - image.tile.xy + offset, ivec2(0), image.tile.zw - 1);
}

// The block of s, whose own texel (texel_of) and its layers z the march has read: that texel and
// its neighbours on the sides of its centre that s lies on (three more reads).
TexelBlock texel_block(sampler2D layers, DepthImage image, vec2 s, ivec2 texel, vec2 z) {
    ivec2 side = ivec2(mix(vec2(-1.0), vec2(1.0), greaterThanEqual(fract(s), vec2(0.5))));
    ivec2 across = texel_beside(image, texel, ivec2(side.x, 0));
    ivec2 up = texel_beside(image, texel, ivec2(0, side.y));
    ivec2 diagonal = texel_beside(image, texel, side);
    vec2 z_across = layers_at(layers, across), z_up = layers_at(layers, up), z_diagonal = layers_at(layers, diagonal);
    TexelBlock block;
    vec4 fronts = vec4(z.x, z_across.x, z_up.x, z_diagonal.x);
    block.nearest = min(min(fronts.x, fronts.y), min(fronts.z, fronts.w));
    vec4 backs = mix(vec4(z.y, z_across.y, z_up.y, z_diagonal.y), vec4(0.0), greaterThanEqual(fronts, vec4(BACKGROUND_DEPTH)));
    block.farthest_back = max(max(backs.x, backs.y), max(backs.z, backs.w));
    block.one_surface = samples_connected(image, texel, across, z.x, z_across.x)
        && samples_connected(image, up, diagonal, z_up.x, z_diagonal.x)
        && samples_connected(image, texel, up, z.x, z_up.x)
        && samples_connected(image, across, diagonal, z_across.x, z_diagonal.x);
    return block;
}

// The visible surface one step `outward` beyond the sample at `texel` (depth z) in `z_beyond`, and
// whether it is joined to it: inside the image, and one surface with it.
bool outer_join(sampler2D layers, DepthImage image, ivec2 texel, ivec2 outward, float z, out float z_beyond) {
    ivec2 beyond = texel + outward - image.tile.xy;
    bool inside = all(greaterThanEqual(beyond, ivec2(0))) && all(lessThan(beyond, image.tile.zw));
    ivec2 read = image.tile.xy + clamp(beyond, ivec2(0), image.tile.zw - 1);
    z_beyond = layers_at(layers, read).x;
    return inside && outward != ivec2(0) && samples_connected(image, texel, read, z, z_beyond);
}

// Does the ray pass between the join of two samples of one surface and the nearest that surface
// can come between them? A join is the surface's chord: where the surface bends toward the eye
// between the samples (a box's edge, a rim, a ledge) it comes in front of it, up to the extension
// of the join beyond either sample (to the sample one step beyond it, where that is of the same
// surface): a ray in front of the join and behind one of the extensions may meet an edge the
// samples step over. Along the step (k in [0, 1]) the ray's depth, the join and the extensions
// are all affine: for each extension, the interval where the ray is behind it, in front of the
// join by more than the contact tolerance (touching the join is a hit) and not clear of the
// silhouette band is clipped as the frustum clips a ray. A flat surface's extensions are its
// join, and a surface bent away from the eye (a hollow) has them behind it: neither is flagged.
bool crease_unseen(sampler2D layers, DepthImage image, ivec2 texel0, ivec2 texel1, float r0, float r1, float z0,
                   float z1) {
    float z_before, z_after;
    bool left = outer_join(layers, image, texel0, texel0 - texel1, z0, z_before);
    bool right = outer_join(layers, image, texel1, texel1 - texel0, z1, z_after);
    float low = 0.0, high = 1.0;
    bool inside = texel0 != texel1;
    clip_half_space(z0 - CONTACT_DEPTH_TOLERANCE - r0, (z1 - z0) - (r1 - r0), low, high, inside);
    clip_half_space(r0 - silhouette_clear_depth(image, min(z0, z1), 1.0), r1 - r0, low, high, inside);
    float left_low = low, left_high = high, right_low = low, right_high = high;
    bool beyond_left = left && inside, beyond_right = right && inside;
    clip_half_space(r0 - z0, (r1 - r0) - (z0 - z_before), left_low, left_high, beyond_left);
    clip_half_space(r0 - (2.0 * z1 - z_after), (r1 - r0) - (z_after - z1), right_low, right_high, beyond_right);
    return (beyond_left && left_low <= left_high) || (beyond_right && right_low <= right_high);
}

// What a step from sample 0 to sample 1 (ray depths r0, r1; layers z0, z1; the texel blocks of both
// samples) that did not hit through the visible surface relies on that the image does not hold
// (UNSEEN_NONE: nothing).
int step_unseen(sampler2D layers, DepthImage image, ivec2 texel0, ivec2 texel1, float r0, float r1, vec2 z0, vec2 z1,
                TexelBlock block0, TexelBlock block1) {
    if (inside_solid(r1, z1)) return UNSEEN_HIDDEN_ENTRY;
    if (occluded(texel1, r1, z1)) return UNSEEN_OCCLUDED;
    // The blocks hold both samples' texels.
    float nearer = min(block0.nearest, block1.nearest);
    if (nearer >= BACKGROUND_DEPTH) return UNSEEN_NONE;
    if (block0.one_surface && block1.one_surface && samples_connected(image, texel0, texel1, z0.x, z1.x)) {
        return crease_unseen(layers, image, texel0, texel1, r0, r1, z0.x, z1.x) ? UNSEEN_SILHOUETTE : UNSEEN_NONE;
    }
    // Clear in front of the nearer surface, or behind the farther back face (in space seen empty:
    // the samples are not occluded, or the step before this one said so). The ray's depth is
    // affine along a step: its ends bound it.
    bool in_front = max(r0, r1) < silhouette_clear_depth(image, nearer, 1.0);
    bool behind = min(r0, r1) > silhouette_clear_depth(image, max(block0.farthest_back, block1.farthest_back), -1.0);
    return in_front || behind ? UNSEEN_NONE : UNSEEN_SILHOUETTE;
}

// Is a hit through a step between joined samples (depths z0, z1 of the layer crossed) on a
// silhouette's: a join steeper than STEEP_JOIN_SHARE of the steepest (it may be a sheet over the
// gap between two surfaces close in depth), or within a texel of where the image is not one
// surface (a nearer edge may reach in front of the join there)?
bool hit_unseen(DepthImage image, ivec2 texel0, ivec2 texel1, float z0, float z1, TexelBlock block0, TexelBlock block1) {
    return !depth_step_within(image, texel0, texel1, z0, z1, STEEP_JOIN_SHARE) || !block0.one_surface || !block1.one_surface;
}

// Record the step from screen parameter sigma0's kind, unless something unseen came before it.
void note_unseen(int kind, float sigma0, ClippedRay ray, inout float unseen_t, inout int unseen) {
    if (kind == UNSEEN_NONE || unseen != UNSEEN_NONE) return;
    unseen = kind;
    unseen_t = ray_parameter(sigma0, ray.pa.z, ray.pb.z, ray.t_enter, ray.t_exit);
}

// Sample i of the march's `steps` along a'b': (u, v, OpenGL depth). Both marches compute every
// sample with this one expression, so that they read the same texels and find the same hit.
vec3 march_sample(ClippedRay ray, int i, int steps) {
    return ray.sa + (ray.sb - ray.sa) * (float(i) / float(steps));
}

// The start of both marches: the ray clipped and projected, its step count, and sample 0 (its
// texel and layers). False, with the answer in `early`, when the ray misses the frustum or starts
// inside the object (a ray that touches the mirror), where it hits at once. `early` also holds
// what sample 0 already relies on that the image does not hold (TRACK_UNSEEN).
bool march_start(sampler2D layers, DepthImage image, vec3 origin, vec3 direction, float t_limit, out ClippedRay ray,
                 out int steps, out ivec2 texel0, out vec2 z0, out TexelBlock block0, out RayHit early) {
    early = no_hit(0);
    if (!clip_and_project(image, origin, direction, t_limit, ray)) return false;
    steps = step_count(image, ray.sa, ray.sb);
    texel0 = texel_of(image, ray.sa.xy);
    z0 = layers_at(layers, texel0);
    block0 = TexelBlock(z0.x, z0.y, true);
#ifdef TRACK_UNSEEN
    block0 = texel_block(layers, image, ray.sa.xy, texel0, z0);
    // Entering the frustum already inside the run or behind it: the object reaches the frustum's
    // side there, where its surface is edge-on to the eye and unseen.
    int kind = inside_solid(ray.sa.z, z0) ? UNSEEN_HIDDEN_ENTRY : occluded(texel0, ray.sa.z, z0) ? UNSEEN_OCCLUDED
                                                                                                 : UNSEEN_NONE;
    note_unseen(kind, 0.0, ray, early.unseen_t, early.unseen);
#endif
    if (!inside_solid(ray.sa.z, z0)) return true;
    early = with_unseen(hit_at(image, ray.t_enter, ray.sa.xy, 1, texel0, 0), early.unseen_t, early.unseen);
    return false;
}

// Step i of the optimized march, from sample i (s0, its texel and layers) to sample i + 1 (s1,
// texel1, z1, returned for the next step). A step hits in one of three ways. Through the visible
// surface: the 2-D segment intersection, between samples of one surface (samples_connected).
// Through the back layer from behind it (back_crossing; `back_colors`: the images keep its
// colour), the same intersection with the back faces' depths. Or into the object through a side
// the image holds nothing of (behind a silhouette): the ray is inside the solid run at s1 without
// crossing either, and the hit is put at s1, within one step of where it entered. A ray that
// passes behind the solid run (behind a thin foreground) is inside nothing and goes on to what
// lies behind, as the truth does. `hit_texel` and `hit_layer` say whose colour the hit shows.
bool march_step(sampler2D layers, bool back_colors, DepthImage image, ClippedRay ray, int i, int steps, vec3 s0,
                ivec2 texel0, vec2 z0, inout TexelBlock blocks, out vec3 s1, out ivec2 texel1, out vec2 z1, out float t, out vec2 s,
                out ivec2 hit_texel, out int hit_layer, inout float unseen_t, inout int unseen) {
    s1 = march_sample(ray, i + 1, steps);
    texel1 = texel_of(image, s1.xy);
    z1 = layers_at(layers, texel1);
    float k;
    bool through_surface = samples_connected(image, texel0, texel1, z0.x, z1.x)
        && segments_cross(s0.z - z0.x, s1.z - z1.x, k);
    bool through_back = back_colors && !through_surface && back_crossing(image, texel0, texel1, s0.z, s1.z, z0, z1, k);
    hit_layer = through_back ? 1 : 0;
#ifdef TRACK_UNSEEN
    // `blocks`: sample 0's on the way in (the step before read it), sample 1's on the way out.
    TexelBlock block0 = blocks, block1 = texel_block(layers, image, s1.xy, texel1, z1);
    blocks = block1;
    vec2 crossed = through_back ? vec2(z0.y, z1.y) : vec2(z0.x, z1.x);
    int kind = through_surface || through_back
        ? (hit_unseen(image, texel0, texel1, crossed.x, crossed.y, block0, block1) ? UNSEEN_SILHOUETTE : UNSEEN_NONE)
        : step_unseen(layers, image, texel0, texel1, s0.z, s1.z, z0, z1, block0, block1);
    note_unseen(kind, float(i) / float(steps), ray, unseen_t, unseen);
#endif
    if (!through_surface && !through_back && !inside_solid(s1.z, z1)) return false;
    if (!through_surface && !through_back) k = 1.0;
    s = s0.xy + (s1.xy - s0.xy) * k;
    hit_texel = k < 0.5 ? texel0 : texel1;  // the sample nearer the crossing: both are surface
    t = ray_parameter((float(i) + k) / float(steps), ray.pa.z, ray.pb.z, ray.t_enter, ray.t_exit);
    return true;
}

// The steps of a march worth taking when nothing beyond t_stop is looked for (the mirror's nearest
// hit so far): those that start at t <= t_stop, since t grows along the march and a step's hit
// lies after its start. The same steps at the same samples as the whole march, so that the hit
// found before t_stop is the whole march's. One step more than the exact count: rounding must not
// end the march a step early.
int steps_before(ClippedRay ray, int steps, float t_stop) {
    if (t_stop >= ray.t_exit) return steps;
    if (t_stop < ray.t_enter) return 0;  // (and t_exit > t_enter: no division by zero below)
    float lambda = (t_stop - ray.t_enter) / (ray.t_exit - ray.t_enter);
    // ray_parameter's inverse: sigma = lambda w_b / ((1 - lambda) w_a + lambda w_b).
    float sigma = lambda * ray.pb.z / ((1.0 - lambda) * ray.pa.z + lambda * ray.pb.z);
    return clamp(int(ceil(sigma * float(steps))) + 1, 0, steps);
}

// The optimized march's loop from sample `first` (s0, its texel and layers) to step `last` (steps:
// the end); `reads` texels were read before it, and `unseen` is what sample 0 relies on that the
// image lacks.
RayHit march_linear(sampler2D layers, bool back_colors, DepthImage image, ClippedRay ray, int steps, int first, int last,
                    vec3 s0, ivec2 texel0, vec2 z0, TexelBlock block0, int reads, RayHit unseen) {
    for (int i = first; i < last; ++i) {
        vec3 s1;
        ivec2 texel1, hit_texel;
        vec2 z1, s;
        float t;
        int hit_layer;
        if (march_step(layers, back_colors, image, ray, i, steps, s0, texel0, z0, block0, s1, texel1, z1, t, s, hit_texel, hit_layer,
                       unseen.unseen_t, unseen.unseen)) {
            return with_unseen(hit_at(image, t, s, reads + i - first + 1, hit_texel, hit_layer), unseen.unseen_t,
                               unseen.unseen);
        }
        s0 = s1;
        texel0 = texel1;
        z0 = z1;
    }
    return with_unseen(no_hit(reads + max(last - first, 0)), unseen.unseen_t, unseen.unseen);
}

// The lecture's optimized algorithm: clip, project both ends, step along the projection and
// intersect 2-D segments in OpenGL depth, which is affine in screen space: no unprojection. It
// reads one texel per step: up to max(w, h) of them. Only hits with t <= t_limit are looked for
// (the ray is clipped there); the march also ends at the step that starts beyond t_stop
// (steps_before: the samples stay those of the whole ray, and so do the hits before t_stop).
RayHit intersect_optimized(sampler2D layers, bool back_colors, DepthImage image, vec3 origin, vec3 direction,
                          float t_limit, float t_stop) {
    ClippedRay ray;
    int steps;
    ivec2 texel0;
    vec2 z0;
    TexelBlock block0;
    RayHit early;
    if (!march_start(layers, image, origin, direction, t_limit, ray, steps, texel0, z0, block0, early)) return early;
    return march_linear(layers, back_colors, image, ray, steps, 0, steps_before(ray, steps, t_stop), ray.sa, texel0, z0,
                        block0, 1, early);
}

#if ALGORITHM == ALGORITHM_HIERARCHICAL || ALGORITHM == ALGORITHM_AUTO
// The min/max depth pyramid (methods/pyramid.py): mip m holds level m + 1 of every image, each
// texel (nearest surface, farthest back of a solid run) over its block grown by one texel.
uniform sampler2D u_impostor_pyramid;

// The first sample after sample i whose (unclamped) position leaves `cell` of `level`, from
// where the line crosses the cell's exit edges. Sample j is at sa + d j / steps: it reaches `high`
// at j >= (high - sa) steps / d and falls below `low` at j > (sa - low) steps / -d, where
// `samples_per_texel` is steps / |d| (Inf on an axis the ray does not move along). Rounding may
// make it one sample early or late: early only shortens the span, and late is caught by the
// caller's footprint check (which is what correctness rests on: whatever span_end returns, a span
// is skipped only when all its samples are in the footprint tested).
int span_end(ClippedRay ray, vec2 samples_per_texel, int steps, int i, ivec2 cell, int level) {
    vec2 d = ray.sb.xy - ray.sa.xy;
    vec2 low = vec2(cell << level), high = vec2((cell + 1) << level);
    vec2 to_exit = mix(ray.sa.xy - low, high - ray.sa.xy, greaterThan(d, vec2(0.0)));
    vec2 crossing = to_exit * samples_per_texel;
    // > 0: the first j at or past `high`; < 0 (and 0): the first j strictly below `low`.
    vec2 end = mix(floor(crossing) + 1.0, ceil(crossing), greaterThan(d, vec2(0.0)));
    float first = min(d.x == 0.0 ? float(steps) : end.x, d.y == 0.0 ? float(steps) : end.y);
    return clamp(int(min(first, float(steps))), i + 1, steps);
}

// The optimized march's hit, found in about log2(max(w, h)) texel reads where the ray passes
// far from the surface. From sample i at `level`: take the span of samples from i to the first
// one leaving the level's cell of sample i; if all their texels lie in the cell's footprint (the
// block grown by one texel) and the ray's depth over the span, which is monotonic in the sample
// index, cannot meet the footprint's [nearest, farthest] (with a margin beyond the march's own
// tolerances), no step of the span can hit: skip it and climb a level. Otherwise descend; at
// level 0 run the march's own step. Every step that could hit is run, in order, by march_step
// itself: the first hit is the linear march's, bit for bit (tests/test_hierarchical.py). So is
// the first thing unseen (TRACK_UNSEEN): until one is found, a span is skipped only where the ray
// is clear of every silhouette band in it, and never behind (whether a sample there is behind a
// run or over background, only the step itself can tell).
RayHit intersect_hierarchical(DepthImage image, vec3 origin, vec3 direction, float t_stop) {
    ClippedRay ray;
    int steps;
    ivec2 texel0;
    vec2 z0;
    TexelBlock block0;
    RayHit early;
    if (!march_start(u_impostor_depth, image, origin, direction, UNBOUNDED_RAY, ray, steps, texel0, z0, block0, early)) return early;
    RayHit unseen = early;
    vec3 s0 = ray.sa;
    bool z0_read = true;
    int reads = 1;
    // A cell wider than the whole projection (2^level > steps texels) skips nothing that a
    // narrower one would not: the coarsest level worth a read is about log2(steps) (rounding of
    // log2 may give one less: a read more, never a wrong answer).
    int top = min(image.pyramid.z, int(log2(float(steps))));
    int level = top;
    int i = 0;
    // A step hits only if |ray - surface| <= CONTACT_DEPTH_TOLERANCE at one of its ends (in
    // float32, whose rounding of values in [0, 1] is far below the tolerance): twice it is safe.
    float margin = 2.0 * CONTACT_DEPTH_TOLERANCE;
    vec2 samples_per_texel = float(steps) / abs(ray.sb.xy - ray.sa.xy);
    // Each pass advances i, or descends a level; a level is climbed only after an advance. So at
    // most steps advances, steps + top descents and as many climbs: this bound is never reached.
    // Up to the step that starts beyond t_stop, as the linear march (steps_before).
    int last = steps_before(ray, steps, t_stop);
    for (int pass = 0; pass <= 4 * steps + top && i < last; ++pass) {
        if (level > 0) {
            ivec2 relative0 = texel0 - image.tile.xy;
            ivec2 cell = relative0 >> level;
            int end = span_end(ray, samples_per_texel, steps, i, cell, level);
            vec3 s_end = march_sample(ray, end, steps);
            ivec2 texel_end = texel_of(image, s_end.xy);
            ivec2 relative_end = texel_end - image.tile.xy;
            if (all(greaterThanEqual(relative_end, (cell << level) - 1)) && all(lessThanEqual(relative_end, (cell + 1) << level))) {
                vec2 span = texelFetch(u_impostor_pyramid, (image.pyramid.xy >> (level - 1)) + cell, level - 1).rg;
                reads += 1;
                float in_front = span.x - margin;
                bool behind = min(s0.z, s_end.z) > span.y + margin;
#ifdef TRACK_UNSEEN
                if (unseen.unseen == UNSEEN_NONE) {
                    // The last step skipped reads the texel block of s_end, which may reach a texel
                    // beyond the cell's grown block.
                    float nearest = min(span.x, texel_block(u_impostor_depth, image, s_end.xy, texel_end,
                                                          layers_at(u_impostor_depth, texel_end)).nearest);
                    in_front = min(in_front, silhouette_clear_depth(image, nearest, 1.0));
                    behind = false;
                }
#endif
                if (max(s0.z, s_end.z) < in_front || behind) {
                    i = end;
                    s0 = s_end;
                    texel0 = texel_end;
                    z0_read = false;
                    level = min(level + 1, top);
                    continue;
                }
            }
            level -= 1;
            continue;
        }
        if (!z0_read) {
            z0 = layers_at(u_impostor_depth, texel0);
            reads += 1;
#ifdef TRACK_UNSEEN
            block0 = texel_block(u_impostor_depth, image, s0.xy, texel0, z0);
#endif
        }
        vec3 s1;
        ivec2 texel1, hit_texel;
        vec2 z1, s;
        float t;
        int hit_layer;
        reads += 1;
        if (march_step(u_impostor_depth, true, image, ray, i, steps, s0, texel0, z0, block0, s1, texel1, z1, t, s, hit_texel, hit_layer,
                       unseen.unseen_t, unseen.unseen)) {
            return with_unseen(hit_at(image, t, s, reads, hit_texel, hit_layer), unseen.unseen_t, unseen.unseen);
        }
        i += 1;
        // Climb only on entering another level-1 cell: within the same one, a level-1 test would
        // most likely fail again, its footprint still holding the surface that sent the march down.
        // (Where to climb decides the cost alone: correctness rests on the footprint check.)
        level = any(notEqual((texel1 - image.tile.xy) >> 1, (texel0 - image.tile.xy) >> 1)) ? min(1, top) : 0;
        s0 = s1;
        texel0 = texel1;
        z0 = z1;
        z0_read = true;
    }
    return with_unseen(no_hit(reads), unseen.unseen_t, unseen.unseen);
}
#endif

// The lecture's basic algorithm: unproject every step's sample to 3-D and intersect the segment
// between consecutive samples with the ray (they are coplanar: both lie in the plane through the
// eye and the ray). Kept as the slower reference point for the optimized version; it enters the
// solid run through hidden sides by the same rule.
RayHit intersect_basic(DepthImage image, vec3 origin, vec3 direction) {
    ClippedRay ray;
    if (!clip_and_project(image, origin, direction, UNBOUNDED_RAY, ray)) return no_hit(0);
    vec3 sa = ray.sa, sb = ray.sb;
    vec3 ray_a = origin + direction * ray.t_enter;
    vec3 ray_ab = direction * (ray.t_exit - ray.t_enter);
    int steps = step_count(image, sa, sb);
    vec2 s0 = sa.xy;
    ivec2 texel0 = texel_of(image, s0);
    vec2 z0 = layers_at(u_impostor_depth, texel0);
    float unseen_t = UNBOUNDED_RAY;
    int unseen = UNSEEN_NONE;
#ifdef TRACK_UNSEEN
    note_unseen(inside_solid(sa.z, z0) ? UNSEEN_HIDDEN_ENTRY : occluded(texel0, sa.z, z0) ? UNSEEN_OCCLUDED : UNSEEN_NONE,
                0.0, ray, unseen_t, unseen);
#endif
    if (inside_solid(sa.z, z0)) return with_unseen(hit_at(image, ray.t_enter, s0, 1, texel0, 0), unseen_t, unseen);
    vec3 q0 = unproject(image, s0, w_from_opengl_depth(image, z0.x));
    for (int i = 0; i < steps; ++i) {
        float sigma0 = float(i) / float(steps);
        float sigma1 = float(i + 1) / float(steps);
        vec2 s1 = sa.xy + (sb.xy - sa.xy) * sigma1;
        ivec2 texel1 = texel_of(image, s1);
        vec2 z1 = layers_at(u_impostor_depth, texel1);
        vec3 q1 = unproject(image, s1, w_from_opengl_depth(image, z1.x));
#ifdef TRACK_UNSEEN
        TexelBlock block0 = texel_block(u_impostor_depth, image, s0, texel0, z0);
        TexelBlock block1 = texel_block(u_impostor_depth, image, s1, texel1, z1);
#endif
        if (samples_connected(image, texel0, texel1, z0.x, z1.x)) {
#ifdef TRACK_UNSEEN
            if (!depth_step_within(image, texel0, texel1, z0.x, z1.x, STEEP_JOIN_SHARE)) {
                note_unseen(UNSEEN_SILHOUETTE, sigma0, ray, unseen_t, unseen);
            }
#endif
            // Closest approach of the lines q0 + mu (q1 - q0) and ray_a + lambda ray_ab.
            vec3 d1 = q1 - q0, d2 = ray_ab, r = q0 - ray_a;
            float aa = dot(d1, d1), bb = dot(d1, d2), cc = dot(d2, d2), dd = dot(d1, r), ee = dot(d2, r);
            float denominator = aa * cc - bb * bb;
            float w_ray0 = 1.0 / ((1.0 - sigma0) / ray.pa.z + sigma0 / ray.pb.z);
            bool in_front_at_start = w_ray0 <= w_from_opengl_depth(image, z0.x);
            // Where the closest approach is ill-conditioned the intersection is the 2-D one in
            // depth (the same point in exact arithmetic), which stays well defined: when both
            // samples come from one texel (a ray through the eye projects to one: q0 and q1 then
            // differ by rounding alone, in no meaningful direction), and when the lines are
            // nearly parallel (a ray lying in the surface; see MIN_LINES_SINE_SQUARED).
            if (texel0 != texel1 && denominator > MIN_LINES_SINE_SQUARED * aa * cc) {
                float mu = (bb * ee - cc * dd) / denominator;
                float lambda = (aa * ee - bb * dd) / denominator;
                if (in_front_at_start && mu >= 0.0 && mu <= 1.0 && lambda >= 0.0 && lambda <= 1.0) {
#ifdef TRACK_UNSEEN
                    if (hit_unseen(image, texel0, texel1, z0.x, z1.x, block0, block1)) {
                        note_unseen(UNSEEN_SILHOUETTE, sigma0, ray, unseen_t, unseen);
                    }
#endif
                    vec3 p = ray_a + ray_ab * lambda;
                    vec3 pc = camera_coordinates(image, p - image.eye.xyz);
                    float t = ray.t_enter + lambda * (ray.t_exit - ray.t_enter);
                    return with_unseen(hit_at(image, t, pc.xy / pc.z, i + 2, mu < 0.5 ? texel0 : texel1, 0), unseen_t, unseen);
                }
            } else {
                float k;
                if (segments_cross(sa.z + (sb.z - sa.z) * sigma0 - z0.x, sa.z + (sb.z - sa.z) * sigma1 - z1.x, k)) {
#ifdef TRACK_UNSEEN
                    if (hit_unseen(image, texel0, texel1, z0.x, z1.x, block0, block1)) {
                        note_unseen(UNSEEN_SILHOUETTE, sigma0, ray, unseen_t, unseen);
                    }
#endif
                    float t = ray_parameter(sigma0 + (sigma1 - sigma0) * k, ray.pa.z, ray.pb.z, ray.t_enter, ray.t_exit);
                    return with_unseen(hit_at(image, t, s0 + (s1 - s0) * k, i + 2, k < 0.5 ? texel0 : texel1, 0), unseen_t, unseen);
                }
            }
        }
        // In through the back layer: the 2-D crossing in depth, as the optimized march finds it.
        float r0 = sa.z + (sb.z - sa.z) * sigma0, r1 = sa.z + (sb.z - sa.z) * sigma1, k_back;
        if (back_crossing(image, texel0, texel1, r0, r1, z0, z1, k_back)) {
#ifdef TRACK_UNSEEN
            if (hit_unseen(image, texel0, texel1, z0.y, z1.y, block0, block1)) {
                note_unseen(UNSEEN_SILHOUETTE, sigma0, ray, unseen_t, unseen);
            }
#endif
            float t = ray_parameter(sigma0 + (sigma1 - sigma0) * k_back, ray.pa.z, ray.pb.z, ray.t_enter, ray.t_exit);
            return with_unseen(hit_at(image, t, s0 + (s1 - s0) * k_back, i + 2, k_back < 0.5 ? texel0 : texel1, 1),
                               unseen_t, unseen);
        }
#ifdef TRACK_UNSEEN
        note_unseen(step_unseen(u_impostor_depth, image, texel0, texel1, r0, r1, z0, z1, block0, block1), sigma0, ray,
                    unseen_t, unseen);
#endif
        if (inside_solid(sa.z + (sb.z - sa.z) * sigma1, z1)) {
            float t = ray_parameter(sigma1, ray.pa.z, ray.pb.z, ray.t_enter, ray.t_exit);
            return with_unseen(hit_at(image, t, s1, i + 2, texel1, 0), unseen_t, unseen);
        }
        s0 = s1;
        texel0 = texel1;
        z0 = z1;
        q0 = q1;
    }
    return with_unseen(no_hit(steps + 1), unseen_t, unseen);
}

// A ray against one of the mirror's depth images, with the algorithm of this variant (the hit's
// colour is left to the caller: see hit_at). Hits after t_stop are of no interest: the optimized
// and hierarchical marches end at the step that starts beyond it (the basic one, the lecture's
// reference point, marches on).
RayHit intersect_depth_image(DepthImage image, vec3 origin, vec3 direction, float t_stop) {
#if ALGORITHM == ALGORITHM_BASIC
    return intersect_basic(image, origin, direction);
#elif ALGORITHM == ALGORITHM_HIERARCHICAL
    return intersect_hierarchical(image, origin, direction, t_stop);
#elif ALGORITHM == ALGORITHM_AUTO
    // Each image's own traversal, chosen by its size (constants.image_algorithm: pyramid.w). A
    // software rasterizer runs both calls' straight-line set-up for a group of pixels, but each
    // one's loop only as long as a pixel of the group takes it.
    if (image.pyramid.w != 0) return intersect_hierarchical(image, origin, direction, t_stop);
    return intersect_optimized(u_impostor_depth, true, image, origin, direction, UNBOUNDED_RAY, t_stop);
#else
    return intersect_optimized(u_impostor_depth, true, image, origin, direction, UNBOUNDED_RAY, t_stop);
#endif
}
