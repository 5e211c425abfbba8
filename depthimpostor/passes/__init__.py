"""Render passes, one module each: environment background, diffuse objects, impostor baking,
mirrors. A pass owns its GL objects and declares the shader variants it compiles."""
