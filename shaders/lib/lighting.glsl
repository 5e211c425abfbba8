// What lights the scene: the ambient term, the lights and the environment's values, in one
// uniform block (layout: constants.LIGHTING). The renderer writes its buffer when the lights move
// (gpu/scene_blocks.py) and binds it once a frame, before the bakes: a program made at any time
// reads the lights as they are now, and no program holds a copy of them.
#include "../generated/lighting.glsl"

layout(std140) uniform Lights {
    Lighting u_lighting;
};
