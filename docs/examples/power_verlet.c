/* A complete contact code for `hcv bench "cmd:./power_verlet"` (protocol hcv-adapter/2).
 *
 * Reads one JSON request on stdin, integrates the normal impact with velocity
 * Verlet and writes the trajectory as JSON on stdout (docs/adapter-protocol.md).
 * Law: U'(q) = k q^p (family "power"; p = 1 Hooke, 1.5 Hertz) with the universal
 * damping C(q) = 2 zeta sqrt(m) U'(q) / sqrt(2 U(q)), U = k q^(p+1) / (p+1).
 * Other families, and "sustained" (two-walls) requests, are declined with
 * {"unsupported": ...}: the suite skips those scenes. Malformed requests are
 * answered with {"error": ...}. Build: cc -O2 -o power_verlet power_verlet.c -lm
 *
 * The JSON reader is deliberately tiny: it finds "key": number pairs by name,
 * which is enough for the request the suite sends (keys are unique per name).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char *read_all(FILE *in) {
    size_t cap = 1 << 16, len = 0, got;
    char *buf = malloc(cap);
    while (buf && (got = fread(buf + len, 1, cap - len - 1, in)) > 0) {
        len += got;
        if (len + 1 == cap) buf = realloc(buf, cap *= 2);
    }
    if (buf) buf[len] = '\0';
    return buf;
}

/* Pointer to the value of "key" (after the colon and blanks), or NULL. */
static const char *value_of(const char *json, const char *key) {
    char pat[64];
    snprintf(pat, sizeof pat, "\"%s\"", key);
    for (const char *s = strstr(json, pat); s; s = strstr(s + 1, pat)) {
        const char *c = s + strlen(pat);
        while (*c == ' ' || *c == '\t' || *c == '\n' || *c == '\r') c++;
        if (*c != ':') continue;
        c++;
        while (*c == ' ' || *c == '\t' || *c == '\n' || *c == '\r') c++;
        return c;
    }
    return NULL;
}

static int number(const char *json, const char *key, double *out) {
    const char *v = value_of(json, key);
    char *end;
    if (!v) return 0;
    *out = strtod(v, &end);
    return end != v;
}

static void fail(const char *why) {
    printf("{\"error\": \"%s\"}\n", why);
    exit(0);
}

/* Decline a scene this code has no model for: a skip, not a failure. */
static void decline(const char *why) {
    printf("{\"unsupported\": \"%s\"}\n", why);
    exit(0);
}

static void put(const char *name, const double *a, long n, int last) {
    printf("\"%s\": [", name);
    for (long i = 0; i < n; i++) {
        if (isfinite(a[i])) printf(i ? ",%.17g" : "%.17g", a[i]);
        else printf(i ? ",null" : "null");
    }
    printf("]%s", last ? "" : ", ");
}

int main(void) {
    char *req = read_all(stdin);
    double k, p, m, v0, dt, nd, zeta = 0.0;
    const char *fam, *law;
    if (!req) fail("cannot read the request");
    const char *what = value_of(req, "request");
    if (what && strncmp(what, "\"impact\"", 8) != 0) decline("single impacts only");
    fam = value_of(req, "family");
    if (!fam || strncmp(fam, "\"power\"", 7) != 0) decline("only power-law potentials");
    if (!number(req, "k", &k) || !number(req, "p", &p) || !number(req, "mass", &m) ||
        !number(req, "v0", &v0) || !number(req, "dt", &dt) || !number(req, "n_steps", &nd))
        fail("request lacks k, p, mass, v0, dt or n_steps");
    law = value_of(req, "law");
    if (law && strncmp(law, "\"universal\"", 11) != 0 && strncmp(law, "\"none\"", 6) != 0)
        decline("integrates the universal damping law (or none) only");
    if (law && strncmp(law, "\"universal\"", 11) == 0 && !number(req, "zeta", &zeta))
        fail("universal damping without zeta");
    long n_max = (long)nd, n = 0;
    double *t = malloc((n_max + 1) * sizeof *t), *q = malloc((n_max + 1) * sizeof *q);
    double *v = malloc((n_max + 1) * sizeof *v), *f = malloc((n_max + 1) * sizeof *f);
    if (!t || !q || !v || !f) fail("out of memory");
    double c = 2.0 * zeta * sqrt(m), y = 0.0, vel = v0, force = 0.0;
    int touched = 0;
    t[0] = 0.0; q[0] = 0.0; v[0] = v0; f[0] = 0.0;
    while (n < n_max) {
        double vh = vel - 0.5 * dt * force / m; /* q > 0 is overlap: force pushes q down */
        y += dt * vh;
        force = 0.0;
        if (y > 0.0) {
            double fe = k * pow(y, p), u = k * pow(y, p + 1.0) / (p + 1.0);
            force = fe + c * fe / sqrt(2.0 * u) * vh;
            touched = 1;
        }
        vel = vh - 0.5 * dt * force / m;
        n++;
        t[n] = n * dt; q[n] = y; v[n] = vel; f[n] = force;
        if ((touched && y <= 0.0) || !isfinite(y)) break;
    }
    printf("{");
    put("t", t, n + 1, 0); put("q", q, n + 1, 0); put("v", v, n + 1, 0); put("force", f, n + 1, 0);
    printf("\"meta\": {\"code\": \"power_verlet.c 1.0\"}}\n");
    return 0;
}
