// Copy one cubemap level between a 2D array texture (6 layers, for upload and readback) and
// the cubemap; moderngl reads and writes cubemap level 0 only.
layout(local_size_x = 8, local_size_y = 8) in;
#if COPY_DIRECTION == to_cube
layout(rgba32f, binding = 0) uniform readonly image2DArray u_from;
layout(rgba32f, binding = 1) uniform writeonly imageCube u_to;
#elif COPY_DIRECTION == from_cube
layout(rgba32f, binding = 0) uniform readonly imageCube u_from;
layout(rgba32f, binding = 1) uniform writeonly image2DArray u_to;
#endif
uniform int u_size;

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (id.x >= u_size || id.y >= u_size) return;
    imageStore(u_to, id, imageLoad(u_from, id));
}
