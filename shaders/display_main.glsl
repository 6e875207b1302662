#include "common.glsl"
#include "tonemap.glsl"
#include "encode.glsl"

// Display program: linear HDR -> exposure -> tone map -> OETF, straight alpha out.
uniform sampler2D u_radiance;
uniform float u_exposure_scale;   // 2^EV
#if BACKDROP
uniform vec3 u_backdrop_srgb;     // the page colour under the render's alpha
#endif
layout(location = 0) out vec4 out_color;

void main() {
    vec4 hdr = texelFetch(u_radiance, ivec2(gl_FragCoord.xy), 0);
#if TRANSPARENT
    vec3 radiance = hdr.a > 0.0 ? hdr.rgb / hdr.a : vec3(0.0);   // un-premultiply
    float alpha = hdr.a;
#else
    vec3 radiance = hdr.rgb;
    float alpha = 1.0;
#endif
    vec3 x = radiance * u_exposure_scale;
#if BUG_DOUBLE_TONEMAP
    x = x / (1.0 + x);   // Reinhard, then the chosen tone map again
#endif
    vec3 display = tonemap(x);
#if BUG_NO_SRGB_ENCODE
    display = saturate(display);
#elif BUG_GAMMA_POW
    display = pow(saturate(display), vec3(1.0 / 2.2));
#elif BUG_DOUBLE_GAMMA
    display = srgb_oetf(srgb_oetf(display));
#else
    display = srgb_oetf(display);
#endif
#if BACKDROP
    out_color = vec4(mix(u_backdrop_srgb, display, alpha), 1.0);   // as a page composites straight alpha
#else
    out_color = vec4(display, alpha);
#endif
}
