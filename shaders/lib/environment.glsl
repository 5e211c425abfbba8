// What a ray sees when it hits nothing: a vertical gradient (a constant environment is the
// gradient with three equal colours). Mirrored by depthimpostor.truth for the ray tracer.
uniform vec3 u_env_zenith;
uniform vec3 u_env_horizon;
uniform vec3 u_env_ground;

vec3 environment(vec3 direction) {
    float y = clamp(safe_normalize(direction, vec3(0.0, 1.0, 0.0)).y, -1.0, 1.0);
    return y >= 0.0 ? mix(u_env_horizon, u_env_zenith, y) : mix(u_env_horizon, u_env_ground, -y);
}
