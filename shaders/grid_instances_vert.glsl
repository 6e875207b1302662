// Triangles given in one instance's frame (GL pixels, y up), drawn once per instance on a grid:
// instance i's frame lies at u_instance_origin + (i % u_instances_x, i / u_instances_x) *
// u_instance_step in the target, whose pixel u_target_origin is the viewport's lower-left.
// Draws the chart's edge pass on rings round the silhouettes (a cell each): a software
// rasterizer shades only what they cover.
in vec2 in_position;
uniform vec2 u_instance_origin;
uniform ivec2 u_instance_step;
uniform int u_instances_x;
uniform vec2 u_target_origin;
uniform ivec2 u_target_size;

void main() {
    ivec2 instance = ivec2(gl_InstanceID % u_instances_x, gl_InstanceID / u_instances_x);
    vec2 pixel = in_position + u_instance_origin + vec2(instance * u_instance_step);
    gl_Position = vec4(2.0 * (pixel - u_target_origin) / vec2(u_target_size) - 1.0, 0.0, 1.0);
}
