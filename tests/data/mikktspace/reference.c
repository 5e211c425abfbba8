/* The reference tangents of the .npz files beside it, by Morten Mikkelsen's mikktspace.c
 * (github.com/mmikk/MikkTSpace at 3e895b49d05e, zlib licence; not part of this repository).
 * A throwaway tool, not built by the package or its tests: make_reference.py compiles it with
 *   gcc -O2 -o reference reference.c mikktspace.c -lm
 * Reads from stdin: int32 vertex count V, int32 triangle count F, then float32 positions (V x 3),
 * normals (V x 3), uvs (V x 2) and int32 faces (F x 3); writes to stdout float32 (F x 3 x 4):
 * each corner's tangent and sign as genTangSpaceDefault gives them (m_setTSpaceBasic). */
#include <stdio.h>
#include <stdlib.h>
#include "mikktspace.h"

typedef struct { int v, f; float *p, *n, *t; int *faces; float *out; } Mesh;

static int faces(const SMikkTSpaceContext *c) { return ((Mesh *)c->m_pUserData)->f; }
static int corners(const SMikkTSpaceContext *c, const int f) { (void)c; (void)f; return 3; }
static int vertex(const SMikkTSpaceContext *c, int f, int k) { return ((Mesh *)c->m_pUserData)->faces[3 * f + k]; }
static void position(const SMikkTSpaceContext *c, float out[], const int f, const int k) {
    const float *p = ((Mesh *)c->m_pUserData)->p + 3 * vertex(c, f, k); out[0] = p[0]; out[1] = p[1]; out[2] = p[2]; }
static void normal(const SMikkTSpaceContext *c, float out[], const int f, const int k) {
    const float *n = ((Mesh *)c->m_pUserData)->n + 3 * vertex(c, f, k); out[0] = n[0]; out[1] = n[1]; out[2] = n[2]; }
static void texcoord(const SMikkTSpaceContext *c, float out[], const int f, const int k) {
    const float *t = ((Mesh *)c->m_pUserData)->t + 2 * vertex(c, f, k); out[0] = t[0]; out[1] = t[1]; }
static void basic(const SMikkTSpaceContext *c, const float tangent[], const float sign, const int f, const int k) {
    float *o = ((Mesh *)c->m_pUserData)->out + 12 * f + 4 * k;
    o[0] = tangent[0]; o[1] = tangent[1]; o[2] = tangent[2]; o[3] = sign; }

static void *take(size_t bytes) {
    void *data = malloc(bytes);
    if (data == NULL || fread(data, 1, bytes, stdin) != bytes) { fprintf(stderr, "short input\n"); exit(1); }
    return data;
}

int main(void) {
    Mesh m;
    SMikkTSpaceInterface api = {0};
    SMikkTSpaceContext context;
    int *counts = take(2 * sizeof(int));
    m.v = counts[0]; m.f = counts[1];
    m.p = take(sizeof(float) * 3 * m.v); m.n = take(sizeof(float) * 3 * m.v); m.t = take(sizeof(float) * 2 * m.v);
    m.faces = take(sizeof(int) * 3 * m.f);
    m.out = calloc(12 * (size_t)m.f, sizeof(float));
    api.m_getNumFaces = faces; api.m_getNumVerticesOfFace = corners; api.m_getPosition = position;
    api.m_getNormal = normal; api.m_getTexCoord = texcoord; api.m_setTSpaceBasic = basic;
    context.m_pInterface = &api; context.m_pUserData = &m;
    if (!genTangSpaceDefault(&context)) { fprintf(stderr, "genTangSpaceDefault failed\n"); return 1; }
    fwrite(m.out, sizeof(float), 12 * (size_t)m.f, stdout);
    return 0;
}
