// Bump-to-depth: the view depth (metres along the camera's forward axis) of a surface point moved
// by its height h (metres, along the unit surface normal n, world space).
float bumped_depth(float depth, float h, vec3 n, vec3 forward) {
    return depth + h * dot(n, forward);
}
