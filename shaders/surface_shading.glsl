// What shading a surface point takes (shade.glsl and every module it calls), included by each
// program that shades one: the chart, the cells stage's probe and its floor prepass. The program
// includes common, hit and scene first.
#include "ggx.glsl"
#include "visibility.glsl"
#include "dfg.glsl"
#include "brdf.glsl"
#if USE_TEXTURES
#include "textures.glsl"
#endif
#include "material.glsl"
#include "env.glsl"
#include "lights.glsl"
#if USE_IBL && BUG_FEWTAP_IBL
#include "ibl_fewtap.glsl"
#elif USE_IBL
#include "ibl.glsl"
#endif
#if FLOOR_PARALLAX
#include "floor_parallax.glsl"
#endif
#if GROUND_IBL
#include "ground_ibl.glsl"
#endif
#if LAYERED_IBL
#include "lobes_ibl.glsl"
#endif
#if USE_AO
#include "ao.glsl"
#endif
#if USE_SHADOWS
#include "shadow.glsl"
#endif
#if NEIGHBOUR_LIGHT
#include "neighbours.glsl"
#endif
#if BOUNCE_CACHE
#include "bounce_cache.glsl"
#endif
#include "shade.glsl"
