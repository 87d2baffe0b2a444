// The orthographic collision camera (world space, metres).
uniform vec3 u_eye;          // camera origin
uniform vec3 u_right;        // unit; screen +x
uniform vec3 u_up;           // unit; screen +y
uniform vec3 u_forward;      // unit; the press direction, into the screen
uniform vec2 u_half_extent;  // half width and height of the view, metres
uniform vec2 u_depth_range;  // near and far distance along u_forward, metres

// Window depth in [0, 1] of a view depth in metres (linear: the camera is orthographic).
float window_depth(float depth) {
    return clamp((depth - u_depth_range.x) / (u_depth_range.y - u_depth_range.x), 0.0, 1.0);
}
