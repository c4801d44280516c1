/* The instance's FMU states: see treb_state.h. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "treb_state.h"

struct TrebSaved {
    TrebSaved *next;
    int state, broken, stopped;
    double start_time;
    TrebModel m;
};

enum { AT_FORMAT = 8, AT_FMI = 12, AT_LAYOUT = 16, AT_STATE = 28, AT_SIZE = 32, AT_SUM = 40,
       AT_START = 48, AT_BROKEN = 56, AT_STOPPED = 60, AT_TOKEN = 64, TOKEN_BYTES = 48 };

const char *treb_state_name(int state)
{
    static const char *const NAME[TREB_NSTATES] = {
        "instantiated", "initialization mode", "step mode", "event mode",
        "continuous-time mode", "terminated", "error", "stopped at the horizon"};
    return state >= 0 && state < TREB_NSTATES ? NAME[state] : "?";
}

void treb_core_new(TrebCore *k, int cosim)
{
    memset(k, 0, sizeof *k);
    k->state = TREB_S_INSTANTIATED;
    treb_model_new(&k->m, cosim);
}

static void drop(TrebCore *k, TrebSaved *s)
{
    for (TrebSaved **p = &k->saved; *p; p = &(*p)->next) {
        if (*p == s) {
            *p = s->next;
            treb_model_free(&s->m);
            free(s);
            return;
        }
    }
}

void treb_core_free(TrebCore *k)
{
    while (k->saved) drop(k, k->saved);
    treb_model_free(&k->m);
}

void treb_core_reset(TrebCore *k)
{
    TrebSaved *saved = k->saved;
    treb_model_reset(&k->m);
    k->state = TREB_S_INSTANTIATED;
    k->broken = k->stopped = 0;
    k->start_time = 0.0;
    k->saved = saved;
}

/* The state p if this instance made it (compared, never dereferenced), else NULL. */
static TrebSaved *find(const TrebCore *k, const void *p)
{
    for (TrebSaved *s = k->saved; s; s = s->next)
        if ((const void *)s == p) return s;
    return NULL;
}

static int fail(char *msg, const char *fn, const char *what)
{
    snprintf(msg, TREB_MSG, "%s: %.400s", fn, what);
    return -1;
}

/* A state of this instance, or a message: NULL, or not one this instance made. */
static TrebSaved *known(TrebCore *k, const void *p, const char *fn, char *msg)
{
    TrebSaved *s = p ? find(k, p) : NULL;
    if (!s) fail(msg, fn, p ? "not an FMU state of this instance (made by another instance, "
                              "freed, or no state at all)" : "the FMU state is NULL");
    return s;
}

/* A new state linked to the instance (the model as instantiated), or NULL. */
static TrebSaved *new_state(TrebCore *k)
{
    TrebSaved *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    treb_model_new(&s->m, k->m.cosim);
    s->next = k->saved;
    k->saved = s;
    return s;
}

int treb_core_get_state(TrebCore *k, void **state, char *msg)
{
    TrebModel copy;
    if (!state) return fail(msg, "fmiGetFMUstate", "the pointer to the FMU state is NULL");
    if (treb_model_copy(&copy, &k->m)) return fail(msg, "fmiGetFMUstate", "out of memory");
    TrebSaved *s = find(k, *state);  /* one of ours is overwritten; anything else is not read */
    if (!s && !(s = new_state(k))) {
        treb_model_free(&copy);
        return fail(msg, "fmiGetFMUstate", "out of memory");
    }
    treb_model_free(&s->m);
    s->m = copy;
    s->state = k->state;
    s->broken = k->broken;
    s->stopped = k->stopped;
    s->start_time = k->start_time;
    *state = s;
    return 0;
}

int treb_core_set_state(TrebCore *k, const void *state, char *msg)
{
    TrebModel copy;
    const TrebSaved *s = known(k, state, "fmiSetFMUstate", msg);
    if (!s) return -1;
    if (treb_model_copy(&copy, &s->m)) return fail(msg, "fmiSetFMUstate", "out of memory");
    treb_model_free(&k->m);
    k->m = copy;
    k->state = s->state;
    k->broken = s->broken;
    k->stopped = s->stopped;
    k->start_time = s->start_time;
    return 0;
}

int treb_core_free_state(TrebCore *k, void **state, char *msg)
{
    if (!state) return fail(msg, "fmiFreeFMUstate", "the pointer to the FMU state is NULL");
    if (!*state) return 0;  /* nothing to free */
    TrebSaved *s = known(k, *state, "fmiFreeFMUstate", msg);
    if (!s) return -1;
    drop(k, s);
    *state = NULL;
    return 0;
}

static size_t size_of(const TrebSaved *s)
{
    return TREB_STATE_HEAD + sizeof(TrebModel) + treb_shot_serialized_size(&s->m.shot);
}

int treb_core_state_size(TrebCore *k, const void *state, size_t *size, char *msg)
{
    const TrebSaved *s = known(k, state, "fmiSerializedFMUstateSize", msg);
    if (!s) return -1;
    if (!size) return fail(msg, "fmiSerializedFMUstateSize", "the pointer to the size is NULL");
    *size = size_of(s);
    return 0;
}

static uint64_t checksum(const unsigned char *p, size_t n)
{
    uint64_t h = 1469598103934665603ULL;  /* FNV-1a, 64 bits */
    for (size_t i = 0; i < n; i++)
        h = (h ^ (i >= AT_SUM && i < AT_SUM + 8 ? 0u : p[i])) * 1099511628211ULL;
    return h;
}

static void put32(unsigned char *buf, int at, uint32_t v) { memcpy(buf + at, &v, sizeof v); }

static uint32_t get32(const unsigned char *buf, int at)
{
    uint32_t v;
    memcpy(&v, buf + at, sizeof v);
    return v;
}

int treb_core_serialize(TrebCore *k, const void *state, int fmi, unsigned char *buf,
                        size_t size, char *msg)
{
    const TrebSaved *s = known(k, state, "fmiSerializeFMUstate", msg);
    if (!s) return -1;
    size_t need = size_of(s);
    uint64_t total = need, sum;
    if (!buf) return fail(msg, "fmiSerializeFMUstate", "the buffer is NULL");
    if (size < need) return fail(msg, "fmiSerializeFMUstate", "the buffer is too small");
    memset(buf, 0, TREB_STATE_HEAD);
    memcpy(buf, TREB_STATE_MAGIC, 8);
    put32(buf, AT_FORMAT, TREB_STATE_FORMAT);
    put32(buf, AT_FMI, (uint32_t)fmi);
    put32(buf, AT_LAYOUT, sizeof(TrebModel));
    put32(buf, AT_LAYOUT + 4, sizeof(TrebShot));
    put32(buf, AT_LAYOUT + 8, sizeof(TrebStep));
    put32(buf, AT_STATE, (uint32_t)s->state);
    memcpy(buf + AT_SIZE, &total, 8);
    memcpy(buf + AT_START, &s->start_time, 8);
    put32(buf, AT_BROKEN, (uint32_t)s->broken);
    put32(buf, AT_STOPPED, (uint32_t)s->stopped);
    snprintf((char *)buf + AT_TOKEN, TOKEN_BYTES, "%s", TREB_GUID);
    TrebModel head = s->m;
    memset(&head.shot, 0, sizeof head.shot);
    memcpy(buf + TREB_STATE_HEAD, &head, sizeof head);
    treb_shot_serialize(&s->m.shot, buf + TREB_STATE_HEAD + sizeof head);
    sum = checksum(buf, need);
    memcpy(buf + AT_SUM, &sum, 8);
    return 0;
}

/* The head of a serialised state: what it says it is, checked. */
static int read_head(const unsigned char *buf, size_t size, int fmi, TrebSaved *s, char *msg)
{
    const char *fn = "fmiDeSerializeFMUstate";
    uint64_t total, sum;
    char token[TOKEN_BYTES];
    if (size < TREB_STATE_HEAD || memcmp(buf, TREB_STATE_MAGIC, 8) != 0)
        return fail(msg, fn, "not a serialised state of this FMU (no TREBSTAT head)");
    if (get32(buf, AT_FORMAT) != TREB_STATE_FORMAT || get32(buf, AT_FMI) != (uint32_t)fmi)
        return fail(msg, fn, "a state of another format version or FMI version");
    if (get32(buf, AT_LAYOUT) != sizeof(TrebModel) || get32(buf, AT_LAYOUT + 4) !=
        sizeof(TrebShot) || get32(buf, AT_LAYOUT + 8) != sizeof(TrebStep))
        return fail(msg, fn, "a state of another build or platform (its layout differs)");
    memcpy(token, buf + AT_TOKEN, TOKEN_BYTES);
    if (token[TOKEN_BYTES - 1] != '\0' || strcmp(token, TREB_GUID) != 0)
        return fail(msg, fn, "a state of another FMU (its token differs)");
    memcpy(&total, buf + AT_SIZE, 8);
    if (total != size) return fail(msg, fn, "the state's size is not the one it was made with");
    memcpy(&sum, buf + AT_SUM, 8);
    if (sum != checksum(buf, size))
        return fail(msg, fn, "the state is corrupted (its checksum does not match)");
    uint32_t state = get32(buf, AT_STATE), broken = get32(buf, AT_BROKEN),
             stopped = get32(buf, AT_STOPPED);
    memcpy(&s->start_time, buf + AT_START, 8);
    if (state >= TREB_NSTATES || broken > 1 || stopped > 1)
        return fail(msg, fn, "the instance's state or flags lie out of range");
    if (!(s->start_time >= 0.0 && s->start_time < TREB_HORIZON))
        return fail(msg, fn, "the start time lies out of range");
    s->state = (int)state;
    s->broken = (int)broken;
    s->stopped = (int)stopped;
    return 0;
}

/* The instance's state agrees with the model: initialised or not, its type, its flags. */
static int consistent(const TrebSaved *s)
{
    int st = s->state, cosim = s->m.cosim;
    if (s->m.initialized ? (st == TREB_S_INSTANTIATED || st == TREB_S_INIT)
                         : !(st == TREB_S_INSTANTIATED || st == TREB_S_INIT
                             || st == TREB_S_ERROR || st == TREB_S_TERMINATED))
        return 0;
    if (cosim ? (st == TREB_S_EVENT || st == TREB_S_CONTINUOUS) : st == TREB_S_STEP)
        return 0;
    if ((st == TREB_S_ERROR) != (s->broken && st != TREB_S_TERMINATED)
        || (st == TREB_S_STOPPED && !s->stopped))
        return 0;
    return !s->stopped || st == TREB_S_STOPPED || st == TREB_S_TERMINATED || st == TREB_S_ERROR;
}

static int read_state(TrebSaved *s, int fmi, int cosim, const unsigned char *buf, size_t size,
                      char *msg)
{
    const char *fn = "fmiDeSerializeFMUstate";
    char why[TREB_MSG];
    if (read_head(buf, size, fmi, s, msg)) return -1;
    if (size < TREB_STATE_HEAD + sizeof(TrebModel))
        return fail(msg, fn, "the state is cut short");
    memcpy(&s->m, buf + TREB_STATE_HEAD, sizeof(TrebModel));
    treb_shot_init_empty(&s->m.shot);  /* the model's shot is read next, never its bytes */
    size_t at = TREB_STATE_HEAD + sizeof(TrebModel);
    if (treb_shot_deserialize(&s->m.shot, buf + at, size - at, why)) return fail(msg, fn, why);
    int complete = s->m.initialized == 1 && cosim && !s->broken;
    if (treb_model_check(&s->m, cosim, complete, why)) return fail(msg, fn, why);
    if (!consistent(s)) return fail(msg, fn, "the instance's state does not fit its model");
    s->m.outputs_valid = 0;  /* computed again from the state, never taken from the bytes */
    return 0;
}

int treb_core_deserialize(TrebCore *k, int fmi, const unsigned char *buf, size_t size,
                          void **state, char *msg)
{
    TrebSaved read;
    const char *fn = "fmiDeSerializeFMUstate";
    if (!buf) return fail(msg, fn, "the serialised state is NULL");
    if (!state) return fail(msg, fn, "the pointer to the FMU state is NULL");
    memset(&read, 0, sizeof read);
    if (read_state(&read, fmi, k->m.cosim, buf, size, msg)) {
        treb_shot_free(&read.m.shot);
        return -1;
    }
    TrebSaved *s = find(k, *state);  /* one of ours is overwritten; anything else is not read */
    if (!s && !(s = new_state(k))) {
        treb_shot_free(&read.m.shot);
        return fail(msg, fn, "out of memory");
    }
    treb_model_free(&s->m);
    read.next = s->next;
    *s = read;
    *state = s;
    return 0;
}
