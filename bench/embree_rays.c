/* Embree 3 alone on a file of rays: what Embree's own walk costs per ray, with no
 * renderer (and no lamina FFI) around it.
 *
 *   cc -O2 -o /tmp/embree_rays bench/embree_rays.c -lembree3 -lpthread
 *   /tmp/embree_rays [options] RAYS.f32 MESH.obj [MESH.obj ...]
 *
 * Mitsuba's wheel carries its own Embree (3.13.4, built inside namespace `mitsuba`);
 * the same program times that build as C++ against the wheel's headers:
 *
 *   M=$(python3 -c "import mitsuba, os; print(os.path.dirname(mitsuba.__file__))")
 *   g++ -x c++ -std=c++20 -O2 -I$M/include -o /tmp/embree_rays_mi bench/embree_rays.c \
 *       -L$M -Wl,-rpath,$M -l:libembree3.so -lpthread
 *
 * RAYS.f32: little-endian float32, eight per ray: origin x y z, tnear, direction x y z,
 * tfar (the start of Embree's RTCRay). bench/mitsuba_rays.py --write-rays writes
 * Mitsuba's own bounce and sun rays in this form, `scene_rays --write-rays` lamina's.
 *
 * MESH.obj: `v x y z` and `f a b c` lines (`a/ta` forms too; only positions are read),
 * each file one triangle geometry, as Mitsuba hands its meshes to Embree.
 *
 * Options:
 *   --robust          RTC_SCENE_FLAG_ROBUST (Mitsuba: RTC_SCENE_FLAG_NONE, the default here)
 *   --quality Q       low | medium | high (Mitsuba: high, the default here)
 *   --quads           faces in pairs (a b c, a c d) made one quad each, as lamina's
 *                     Embree backend hands cards to Embree
 *   --threads N       worker threads (default 2)
 *   --repeat N        timed runs per mode, the best counts (default 3)
 *   --scramble        trace the rays in a scrambled order (i -> i*a mod n, as
 *                     mitsuba_rays.py's bounce_shuffled)
 *   --device CFG      more of rtcNewDevice's configuration, e.g. `isa=avx2` (Embree's
 *                     AVX2 kernels on an AVX-512 machine) or `verbose=1`
 *
 * Printed, per mode: rays, hits (or blocked), best seconds, M rays/s. Modes:
 * `intersect1` (rtcIntersect1 per ray), `intersect16` (rtcIntersect16 on runs of 16
 * consecutive rays, as Mitsuba's LLVM back end calls it on an AVX-512 machine),
 * `occluded1`, `occluded16`.
 */
#include <embree3/rtcore.h>
#include <pthread.h>
#ifdef __cplusplus
/* As C++ (`g++ -x c++`), for an Embree built inside a namespace, as Mitsuba's is. */
#include <atomic>
typedef std::atomic<size_t> atomic_size_t;
#define atomic_fetch_add(p, v) ((p)->fetch_add(v))
#define atomic_init(p, v) ((p)->store(v))
#define atomic_load(p) ((p)->load())
RTC_NAMESPACE_USE
#else
#include <stdatomic.h>
#endif
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifndef __cplusplus
/* Embree 3's C header declares these as bare structs and enums. */
typedef struct RTCIntersectContext RTCIntersectContext;
typedef struct RTCRayHit RTCRayHit;
typedef struct RTCRay RTCRay;
typedef struct RTCRayHit16 RTCRayHit16;
typedef enum RTCBuildQuality RTCBuildQuality;
#endif

typedef struct {
    float o[3], tnear, d[3], tfar;
} Ray8;

static void die(const char *what, const char *detail) {
    fprintf(stderr, "embree_rays: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* One OBJ file: its positions and triangles (or quads). */
static RTCGeometry load_obj(RTCDevice dev, const char *path, int quads) {
    FILE *f = fopen(path, "r");
    if (!f) die("cannot open", path);
    size_t nv = 0, cv = 1024, nt = 0, ct = 1024;
    float *v = (float *)malloc(cv * 3 * sizeof(float));
    unsigned *t = (unsigned *)malloc(ct * 3 * sizeof(unsigned));
    char line[512];
    int lineno = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        if (line[0] == 'v' && line[1] == ' ') {
            if (nv == cv) v = (float *)realloc(v, (cv *= 2) * 3 * sizeof(float));
            if (sscanf(line + 2, "%f %f %f", &v[3 * nv], &v[3 * nv + 1], &v[3 * nv + 2]) != 3) {
                fprintf(stderr, "embree_rays: %s:%d: a `v` line without three numbers\n", path, lineno);
                exit(2);
            }
            nv++;
        } else if (line[0] == 'f' && line[1] == ' ') {
            long idx[3];
            char *p = line + 2;
            for (int k = 0; k < 3; k++) {
                char *end;
                idx[k] = strtol(p, &end, 10);
                if (end == p || idx[k] < 1) {
                    fprintf(stderr, "embree_rays: %s:%d: a face that is not three positive indices\n", path, lineno);
                    exit(2);
                }
                p = end;
                while (*p && *p != ' ' && *p != '\t') p++;
            }
            if (nt == ct) t = (unsigned *)realloc(t, (ct *= 2) * 3 * sizeof(unsigned));
            for (int k = 0; k < 3; k++) t[3 * nt + k] = (unsigned)(idx[k] - 1);
            nt++;
        }
    }
    fclose(f);
    for (size_t i = 0; i < 3 * nt; i++)
        if (t[i] >= nv) die("a face index past the vertices in", path);
    RTCGeometry g;
    if (quads) {
        if (nt % 2) die("--quads: an odd number of triangles in", path);
        g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_QUAD);
        unsigned *q = (unsigned *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4,
                                              4 * sizeof(unsigned), nt / 2);
        for (size_t i = 0; i < nt / 2; i++) {
            const unsigned *a = t + 6 * i, *b = a + 3;
            if (a[0] != b[0] || a[2] != b[1]) die("--quads: faces not in (a b c, a c d) pairs in", path);
            q[4 * i] = a[0];
            q[4 * i + 1] = a[1];
            q[4 * i + 2] = a[2];
            q[4 * i + 3] = b[2];
        }
    } else {
        g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        unsigned *q = (unsigned *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                              3 * sizeof(unsigned), nt);
        memcpy(q, t, nt * 3 * sizeof(unsigned));
    }
    float *vb = (float *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                        3 * sizeof(float), nv);
    memcpy(vb, v, nv * 3 * sizeof(float));
    rtcCommitGeometry(g);
    fprintf(stderr, "%s: %zu vertices, %zu triangles%s\n", path, nv, nt, quads ? " (as quads)" : "");
    free(v);
    free(t);
    return g;
}

enum { INTERSECT1, INTERSECT16, OCCLUDED1, OCCLUDED16, MODES };
static const char *MODE_NAME[MODES] = {"intersect1", "intersect16", "occluded1", "occluded16"};

typedef struct {
    RTCScene scene;
    const Ray8 *rays;
    size_t n;
    int mode;
    atomic_size_t next;
    atomic_size_t hits;
} Job;

#define CHUNK 4096

static void *worker(void *arg) {
    Job *job = (Job *)arg;
    size_t hits = 0;
    RTCIntersectContext ctx;
    for (;;) {
        size_t start = atomic_fetch_add(&job->next, CHUNK);
        if (start >= job->n) break;
        size_t end = start + CHUNK < job->n ? start + CHUNK : job->n;
        if (job->mode == INTERSECT1 || job->mode == OCCLUDED1) {
            for (size_t i = start; i < end; i++) {
                const Ray8 *r = &job->rays[i];
                rtcInitIntersectContext(&ctx);
                if (job->mode == INTERSECT1) {
                    RTCRayHit rh;
                    rh.ray.org_x = r->o[0];
                    rh.ray.org_y = r->o[1];
                    rh.ray.org_z = r->o[2];
                    rh.ray.tnear = r->tnear;
                    rh.ray.dir_x = r->d[0];
                    rh.ray.dir_y = r->d[1];
                    rh.ray.dir_z = r->d[2];
                    rh.ray.time = 0.0f;
                    rh.ray.tfar = r->tfar;
                    rh.ray.mask = (unsigned)-1;
                    rh.ray.id = 0;
                    rh.ray.flags = 0;
                    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                    rtcIntersect1(job->scene, &ctx, &rh);
                    hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
                } else {
                    RTCRay ray;
                    ray.org_x = r->o[0];
                    ray.org_y = r->o[1];
                    ray.org_z = r->o[2];
                    ray.tnear = r->tnear;
                    ray.dir_x = r->d[0];
                    ray.dir_y = r->d[1];
                    ray.dir_z = r->d[2];
                    ray.time = 0.0f;
                    ray.tfar = r->tfar;
                    ray.mask = (unsigned)-1;
                    ray.id = 0;
                    ray.flags = 0;
                    rtcOccluded1(job->scene, &ctx, &ray);
                    hits += ray.tfar < 0.0f;
                }
            }
        } else {
            for (size_t i = start; i < end; i += 16) {
                int valid[16];
                RTCRayHit16 rh __attribute__((aligned(64)));
                size_t m = end - i < 16 ? end - i : 16;
                for (size_t k = 0; k < 16; k++) {
                    const Ray8 *r = &job->rays[i + (k < m ? k : 0)];
                    valid[k] = k < m ? -1 : 0;
                    rh.ray.org_x[k] = r->o[0];
                    rh.ray.org_y[k] = r->o[1];
                    rh.ray.org_z[k] = r->o[2];
                    rh.ray.tnear[k] = r->tnear;
                    rh.ray.dir_x[k] = r->d[0];
                    rh.ray.dir_y[k] = r->d[1];
                    rh.ray.dir_z[k] = r->d[2];
                    rh.ray.time[k] = 0.0f;
                    rh.ray.tfar[k] = r->tfar;
                    rh.ray.mask[k] = (unsigned)-1;
                    rh.ray.id[k] = 0;
                    rh.ray.flags[k] = 0;
                    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                }
                rtcInitIntersectContext(&ctx);
                if (job->mode == INTERSECT16) {
                    rtcIntersect16(valid, job->scene, &ctx, &rh);
                    for (size_t k = 0; k < m; k++) hits += rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
                } else {
                    rtcOccluded16(valid, job->scene, &ctx, &rh.ray);
                    for (size_t k = 0; k < m; k++) hits += rh.ray.tfar[k] < 0.0f;
                }
            }
        }
    }
    atomic_fetch_add(&job->hits, hits);
    return NULL;
}

int main(int argc, char **argv) {
    int robust = 0, quads = 0, threads = 2, repeat = 3, scramble = 0;
    const char *device = NULL;
    RTCBuildQuality quality = RTC_BUILD_QUALITY_HIGH;
    int a = 1;
    for (; a < argc && strncmp(argv[a], "--", 2) == 0; a++) {
        if (!strcmp(argv[a], "--robust")) robust = 1;
        else if (!strcmp(argv[a], "--quads")) quads = 1;
        else if (!strcmp(argv[a], "--scramble")) scramble = 1;
        else if (!strcmp(argv[a], "--threads") && a + 1 < argc) threads = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--repeat") && a + 1 < argc) repeat = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--device") && a + 1 < argc) device = argv[++a];
        else if (!strcmp(argv[a], "--quality") && a + 1 < argc) {
            a++;
            if (!strcmp(argv[a], "low")) quality = RTC_BUILD_QUALITY_LOW;
            else if (!strcmp(argv[a], "medium")) quality = RTC_BUILD_QUALITY_MEDIUM;
            else if (!strcmp(argv[a], "high")) quality = RTC_BUILD_QUALITY_HIGH;
            else die("--quality takes low, medium or high, not", argv[a]);
        } else die("unknown option (or one missing its value)", argv[a]);
    }
    if (threads < 1 || repeat < 1) die("--threads and --repeat must be at least 1", NULL);
    if (argc - a < 2) die("usage: embree_rays [options] RAYS.f32 MESH.obj [MESH.obj ...]", NULL);

    FILE *rf = fopen(argv[a], "rb");
    if (!rf) die("cannot open", argv[a]);
    fseek(rf, 0, SEEK_END);
    long bytes = ftell(rf);
    fseek(rf, 0, SEEK_SET);
    if (bytes <= 0 || bytes % sizeof(Ray8)) die("not a whole number of 32-byte rays", argv[a]);
    size_t n = bytes / sizeof(Ray8);
    Ray8 *rays = (Ray8 *)aligned_alloc(64, (bytes + 63) / 64 * 64);
    if (fread(rays, sizeof(Ray8), n, rf) != n) die("short read", argv[a]);
    fclose(rf);
    if (scramble) {
        /* Moved, not indexed, so that the timing is the engine's, not the memory's. */
        size_t mult = 2654435761u % n;
        for (;;) {
            size_t x = mult, y = n;
            while (y) { size_t r = x % y; x = y; y = r; }
            if (x == 1) break;
            mult++;
        }
        Ray8 *s = (Ray8 *)aligned_alloc(64, (bytes + 63) / 64 * 64);
        for (size_t i = 0; i < n; i++) s[i] = rays[(size_t)(((unsigned __int128)i * mult) % n)];
        free(rays);
        rays = s;
    }

    char cfg[256];
    snprintf(cfg, sizeof cfg, "threads=%d%s%s", threads, device ? "," : "", device ? device : "");
    RTCDevice dev = rtcNewDevice(cfg);
    if (!dev) die("rtcNewDevice failed", NULL);
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    rtcSetSceneBuildQuality(scene, quality);
    for (int k = a + 1; k < argc; k++) {
        RTCGeometry g = load_obj(dev, argv[k], quads);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    double t0 = now();
    rtcCommitScene(scene);
    fprintf(stderr, "build %.3f s; %zu rays from %s%s; %d threads, best of %d; %s, quality %s, %s\n",
            now() - t0, n, argv[a], scramble ? " (scrambled)" : "", threads, repeat,
            robust ? "ROBUST" : "flags NONE",
            quality == RTC_BUILD_QUALITY_HIGH ? "high" : quality == RTC_BUILD_QUALITY_MEDIUM ? "medium" : "low",
            quads ? "quads" : "triangles");

    printf("%-12s %10s %10s %9s %9s\n", "mode", "rays", "hits", "seconds", "Mrays/s");
    for (int mode = 0; mode < MODES; mode++) {
        double best = 1e30;
        size_t hits = 0;
        for (int r = 0; r < repeat; r++) {
            Job job = {.scene = scene, .rays = rays, .n = n, .mode = mode};
            atomic_init(&job.next, 0);
            atomic_init(&job.hits, 0);
            pthread_t th[64];
            int nth = threads < 64 ? threads : 64;
            double s = now();
            for (int k = 0; k < nth; k++) pthread_create(&th[k], NULL, worker, &job);
            for (int k = 0; k < nth; k++) pthread_join(th[k], NULL);
            double e = now() - s;
            if (e < best) best = e;
            hits = atomic_load(&job.hits);
        }
        printf("%-12s %10zu %10zu %9.3f %9.2f\n", MODE_NAME[mode], n, hits, best, n / best * 1e-6);
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
    free(rays);
    return 0;
}
