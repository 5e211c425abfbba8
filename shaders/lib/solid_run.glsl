// The solid run a depth-image texel stands for, from its two layers (visible surface, nearest
// back face behind it): (front, back) in OpenGL depth (reference.sample_layers). Where no back
// face was drawn (an open surface) the object is taken to be as thin as it looks: no false solid
// behind it. The traversals and the depth pyramid's build share it, so that the pyramid bounds
// exactly what the traversals test.
vec2 solid_run(vec2 layers) {
    return vec2(layers.x, layers.y >= BACKGROUND_DEPTH ? layers.x : max(layers.x, layers.y));
}
