// One camera path recorded vertex by vertex for the adjoint passes, by the integrator itself: the OBSERVE_*
// hooks of render/path_trace.glsl write the record (the Rust twin's PathObserver methods). A kernel includes
// this file before render/path_trace.glsl; the record lives in invocation-private memory, at most
// MAX_RECORD_DEPTH vertices (the host refuses deeper paths).
// Rust twin: psdr/src/grad/path/record.rs (the Recorder's start, hit, emission, scatter, nee, continuation;
// PathRecord::radiance).
// GLSL only: recorder_flush (stores the finished vertex; a Rust Vec is written in place).
#ifndef PSDR_RECORD_GLSL
#define PSDR_RECORD_GLSL
#include "render/layout.glsl"
#include "render/scene_buffers.glsl"
#include "render/bvh.glsl"
#include "render/shading.glsl"
#include "render/light.glsl"

const uint MAX_RECORD_DEPTH = 16u;

// The fields of the Rust twin's RecordedVertex that the GPU adjoints read (emission, next-event and
// continuation terms; their detached densities; the texture coordinates after the uv transform; the triangles
// and world directions a geometric replay follows).
struct RecordedVertex {
    vec3 throughput;
    uint material;
    vec2 uv;
    uint triangle;
    float u;
    float v;
    vec3 emission;
    uint emitter;
    vec3 emission_shape;
    float emission_mis;
    vec3 local;
    vec3 wi_local;
    BsdfParams bsdf;
    bool has_nee;
    uint nee_triangle;
    vec3 nee_dir;
    uint nee_emitter;
    float nee_w_over_pdf;
    vec3 nee_radiance;
    vec3 nee_f;
    vec3 nee_wo_local;
    bool has_next;
    vec3 next_dir;
    float next_pdf;
    float next_q;
    vec3 next_beta;
    vec3 next_wo_local;
};

RecordedVertex rec_vertices[MAX_RECORD_DEPTH];
uint rec_count;
// The camera ray the path starts with.
vec3 rec_origin;
vec3 rec_dir;
// False while a kernel traces paths it must not record (a boundary sample's side paths, which would overwrite
// the camera path being swept).
bool rec_enabled = true;
// The vertex whose events are arriving. Events write its fields here and recorder_flush stores it whole into
// rec_vertices: field writes through a dynamic index into the private array were dropped by lavapipe's
// compiler (Mesa 22.3) when the array was read back in another loop, while whole-element stores survive.
RecordedVertex rec_current;

// Stores the vertex being recorded (after its last event: at the next hit and when the path ends).
void recorder_flush() {
    if (rec_count > 0u) {
        rec_vertices[rec_count - 1u] = rec_current;
    }
}

void recorder_start(vec3 origin, vec3 dir) {
    rec_origin = origin;
    rec_dir = dir;
}

void recorder_hit(Hit hit, SurfacePoint sp, vec3 beta) {
    recorder_flush();
    RecordedVertex v;
    v.throughput = beta;
    v.material = triangles[hit.triangle].material;
    v.uv = sp.uv;
    v.triangle = hit.triangle;
    v.u = hit.u;
    v.v = hit.v;
    v.emission = vec3(0.0);
    v.emitter = NONE;
    v.emission_shape = vec3(0.0);
    v.emission_mis = 0.0;
    v.local = vec3(0.0);
    v.wi_local = vec3(0.0);
    v.bsdf = sp.bsdf;
    v.has_nee = false;
    v.nee_triangle = NONE;
    v.nee_dir = vec3(0.0);
    v.nee_emitter = NONE;
    v.nee_w_over_pdf = 0.0;
    v.nee_radiance = vec3(0.0);
    v.nee_f = vec3(0.0);
    v.nee_wo_local = vec3(0.0);
    v.has_next = false;
    v.next_dir = vec3(0.0);
    v.next_pdf = 1.0;
    v.next_q = 1.0;
    v.next_beta = vec3(0.0);
    v.next_wo_local = vec3(0.0);
    rec_current = v;
    rec_count += 1u;
}

void recorder_emission(uint emitter, vec3 le, vec3 shape, float mis) {
    rec_current.emitter = emitter;
    rec_current.emission = le;
    rec_current.emission_shape = shape;
    rec_current.emission_mis = mis;
    rec_current.local += le * mis;
}

void recorder_scatter(vec3 wi) {
    rec_current.wi_local = wi;
}

void recorder_nee(float u_select, vec3 dir, uint emitter, vec3 radiance, float w_over_pdf, vec3 f, vec3 wo) {
    rec_current.local += f * radiance * w_over_pdf;
    rec_current.has_nee = true;
    rec_current.nee_triangle = lights[select_light(fp.light_count, u_select)].triangle;
    rec_current.nee_dir = dir;
    rec_current.nee_emitter = emitter;
    rec_current.nee_w_over_pdf = w_over_pdf;
    rec_current.nee_radiance = radiance;
    rec_current.nee_f = f;
    rec_current.nee_wo_local = wo;
}

void recorder_continuation(vec3 dir, float pdf, float q, vec3 weight, vec3 wo) {
    rec_current.has_next = true;
    rec_current.next_dir = dir;
    rec_current.next_pdf = pdf;
    rec_current.next_q = q;
    rec_current.next_beta = weight / q; // q is 1 before roulette: exact
    rec_current.next_wo_local = wo;
}

// The recorded path's radiance estimate, Σ_k T_k (e_k + n_k) (what the integrator returns, up to rounding).
vec3 path_record_radiance() {
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < rec_count; k++) {
        sum += rec_vertices[k].throughput * rec_vertices[k].local;
    }
    return sum;
}

#define OBSERVE_START(origin, dir) if (rec_enabled) recorder_start(origin, dir)
#define OBSERVE_HIT(hit, sp, beta) if (rec_enabled) recorder_hit(hit, sp, beta)
#define OBSERVE_EMISSION(emitter, le, shape, mis) if (rec_enabled) recorder_emission(emitter, le, shape, mis)
#define OBSERVE_SCATTER(wi) if (rec_enabled) recorder_scatter(wi)
#define OBSERVE_NEE(u_select, wl, emitter, radiance, w_over_pdf, f, wo) if (rec_enabled) recorder_nee(u_select, wl, emitter, radiance, w_over_pdf, f, wo)
#define OBSERVE_CONTINUATION(dir, pdf, q, weight, wo) if (rec_enabled) recorder_continuation(dir, pdf, q, weight, wo)

#endif
