// Glass (passes/glass.py): what a glass pixel shows. Schlick's Fresnel term blends the reflected
// ray's colour with the refracted ray's, which is followed through the object to where it leaves
// and refracts again (Snell's law both times), the share Fresnel reflects there followed inside
// (all of it past the critical angle: total internal reflection), at most MAX_INTERNAL_REFLECTIONS
// times; what is still inside then carries no light. truth.py's glass follows the same rules.
//
// Where the ray leaves is found in the glass's interior image: a depth image of the glass alone
// from the viewpoint that sees it (the camera, or a mirror's centre when a bounce is baked), with
// the front faces and the back faces in two layers (outward normal, window depth). A ray inside
// the glass lies between the two; it leaves at the first step where it does not, and the crossing
// is the 2-D segment intersection of the depth-image march, with the layer it crossed.
#include "depth_image.glsl"

layout(std140) uniform GlassInterior {
    DepthImage u_glass_interior;  // its tile is the texture's corner (0, 0)
};
// Filtered linearly for the normals (layer_normal); depths are read texel by texel (texelFetch).
uniform sampler2D u_glass_front;  // (outward normal, window depth) of the front faces; depth 1 = nothing
uniform sampler2D u_glass_back;   // the same for the nearest back faces
// False when no interior image could be fitted (the viewpoint inside the glass's bounds): the
// refracted ray then goes on from the entry point, as through a thin sheet.
uniform bool u_glass_has_interior;
uniform float u_ior;

// The normal of a layer at image point s, interpolated bilinearly between its four texels (the
// nearest one alone would facet the refraction at the texels' size). A texel off the silhouette
// holds a zero normal, which shortens the mix but does not turn it; `nearest` is for a mix of
// nothing at all.
vec3 layer_normal(sampler2D layer, vec2 s, vec3 nearest) {
    vec3 mixed = texture(layer, s / vec2(textureSize(layer, 0))).xyz;
    return safe_normalize(mixed, nearest);
}

// Where origin + t * direction, inside the glass, leaves it: the point and the outward normal
// there. False when the interior image cannot say (the ray leaves its frustum first).
bool glass_exit(vec3 origin, vec3 direction, out vec3 exit_point, out vec3 exit_normal, inout int samples) {
    DepthImage image = u_glass_interior;
    ClippedRay ray;
    exit_point = origin;
    exit_normal = vec3(0.0);
    if (!clip_and_project(image, origin, direction, UNBOUNDED_RAY, ray)) return false;
    int steps = step_count(image, ray.sa, ray.sb);
    vec3 s0 = ray.sa;
    ivec2 texel0 = texel_of(image, s0.xy);
    vec4 front0 = texelFetch(u_glass_front, texel0, 0), back0 = texelFetch(u_glass_back, texel0, 0);
    bool entered = false;
    for (int i = 0; i < steps; ++i) {
        vec3 s1 = march_sample(ray, i + 1, steps);
        ivec2 texel1 = texel_of(image, s1.xy);
        vec4 front1 = texelFetch(u_glass_front, texel1, 0), back1 = texelFetch(u_glass_back, texel1, 0);
        samples += 1;
        // Leaving: off the silhouette (no glass at s1), behind the back face, or (a ray reflected
        // inside, heading back) in front of the front face. Touching either is still inside.
        bool off_glass = back1.w >= BACKGROUND_DEPTH;
        bool past_back = !off_glass && s1.z > back1.w + CONTACT_DEPTH_TOLERANCE;
        bool before_front = !off_glass && front1.w < BACKGROUND_DEPTH && s1.z < front1.w - CONTACT_DEPTH_TOLERANCE;
        // The ray starts on the surface, inside by construction, but a texel is a step of depth
        // where the surface is steep (near the silhouette, where grazing rays enter): the texels
        // it starts in may put it outside. Only a sample that sees it inside makes a later one
        // seeing it outside an exit; until then only leaving the glass's silhouette is one.
        if (!entered && !off_glass) {
            entered = !past_back && !before_front;
            past_back = before_front = false;
        }
        if (off_glass || past_back || before_front) {
            float k;
            if (off_glass) {
                // Out through the rim, where front and back meet within the step: at its start,
                // on the layer the ray is nearer to there.
                k = 0.0;
                exit_normal = abs(s0.z - front0.w) < abs(s0.z - back0.w) ? front0.xyz : back0.xyz;
            } else if (past_back) {
                segments_cross(s0.z - back0.w, s1.z - back1.w, k);  // where along the step
                exit_normal = k < 0.5 ? back0.xyz : back1.xyz;
            } else {
                segments_cross(front0.w - s0.z, front1.w - s1.z, k);
                exit_normal = k < 0.5 ? front0.xyz : front1.xyz;
            }
            vec2 s = s0.xy + (s1.xy - s0.xy) * k;
            if (past_back) exit_normal = layer_normal(u_glass_back, s, exit_normal);
            if (before_front) exit_normal = layer_normal(u_glass_front, s, exit_normal);
            float t = ray_parameter((float(i) + k) / float(steps), ray.pa.z, ray.pb.z, ray.t_enter, ray.t_exit);
            exit_point = origin + direction * t;
            return exit_normal != vec3(0.0);
        }
        s0 = s1;
        front0 = front1;
        back0 = back1;
    }
    return false;
}

// Schlick's approximation of the Fresnel reflectance at an air-glass surface, from the cosine of
// the angle on the air side (outside, for light leaving: at the critical angle that angle is 90
// degrees and the reflectance 1, so the light that leaves fades out into total internal
// reflection continuously, and a small error in a normal near it costs little).
float schlick(float air_cosine) {
    float r0 = (u_ior - 1.0) / (u_ior + 1.0);
    float f0 = r0 * r0;
    return f0 + (1.0 - f0) * pow(1.0 - clamp(air_cosine, 0.0, 1.0), 5.0);
}

// What the ray refracted into the glass at `entry` brings back out. At each surface it meets
// inside, the share 1 - F leaves (refracted, and traced from there like a reflected ray) and F
// reflects inside, followed MAX_INTERNAL_REFLECTIONS times at most and no further once its share
// is under MIN_PATH_WEIGHT (an 8-bit step): one exit traced for a ray that leaves at once, two or
// three near and past the critical angle.
vec3 glass_transmitted(vec3 entry, vec3 direction, inout int samples) {
    vec3 p = entry, d = direction, color = vec3(0.0);
    float weight = 1.0;
    for (int reflections = 0; reflections <= MAX_INTERNAL_REFLECTIONS && weight >= MIN_PATH_WEIGHT; ++reflections) {
        vec3 q, outward;
        if (!u_glass_has_interior || !glass_exit(p, d, q, outward, samples)) {
            RayHit through = trace_reflected(p, d);  // no interior to follow: leave unbent
            samples += through.samples;
            return color + weight * through.color;
        }
        // Facing the ray, as refract() and reflect() expect, whichever layer it came from.
        vec3 inward = faceforward(outward, d, outward);
        vec3 leaving = refract(d, inward, u_ior);
        float reflectance = leaving == vec3(0.0) ? 1.0 : schlick(-dot(leaving, inward));
        if (reflectance < 1.0) {
            RayHit seen = trace_reflected(q, leaving);
            samples += seen.samples;
            color += weight * (1.0 - reflectance) * seen.color;
        }
        weight *= reflectance;
        p = q;
        d = reflect(d, inward);
    }
    return color;  // what is still inside carries no light
}

// A glass pixel at `position`, seen along the unit `view` with the unit `normal` facing it, whose
// reflected ray saw `reflected`: F reflected + (1 - F) tint transmitted.
vec3 glass_color(vec3 position, vec3 view, vec3 normal, vec3 reflected, vec3 tint, inout int samples) {
    float fresnel = schlick(-dot(view, normal));
    // From air into glass (eta < 1) refract() never meets the critical angle.
    vec3 transmitted = glass_transmitted(position, refract(view, normal, 1.0 / u_ior), samples);
    return mix(tint * transmitted, reflected, fresnel);
}
