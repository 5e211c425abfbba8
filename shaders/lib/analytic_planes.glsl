// The analytic planes (floors and walls that are not mirrors), which every method intersects
// exactly, in one uniform block (layout: constants.PLANES). Written when a plane moves and bound
// once a frame, as the lights are (gpu/scene_blocks.py).
#include "../generated/planes.glsl"

layout(std140) uniform AnalyticPlanes {
    Planes u_planes;
};
