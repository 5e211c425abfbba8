"""The GPU side that every pass shares: the one place contexts are made (context.py), GLSL and the
program cache (shaders.py), the table of texture units and bindings (bindings.py), GL state scopes
(gl_state.py), what a context can hold (limits.py), living in a caller's context (embedding.py), and
the scene's meshes, image textures and uniforms on the GPU (meshes.py, textures.py, uniforms.py), its
lights and analytic planes in uniform blocks (scene_blocks.py) laid out under std140 (std140.py)."""
