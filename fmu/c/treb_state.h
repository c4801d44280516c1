/* What fmi2.c and fmi3.c share beside the model: the instance's state machine and its FMU
 * states (get, set, free, serialise, deserialise), none of which trusts what the host hands
 * in. A pointer to an FMU state is used only if this instance made it and has not freed it
 * (it is looked up, never dereferenced first); serialised bytes are used only after their
 * size, format, version, layout, FMU token and checksum, and every count, index, kind and
 * number they hold, are checked (treb_model_check, treb_shot_check).
 *
 * The serialised state: a head of TREB_STATE_HEAD bytes, the model (TrebModel, its shot
 * zeroed), the shot (TrebShot, its pointers zeroed) and the shot's steps and flight steps
 * (TrebStep each). The head, native byte order:
 *
 *     0  "TREBSTAT"         8 bytes           32  total size, bytes           uint64
 *     8  format (1)         uint32            40  checksum                    uint64
 *    12  FMI version        uint32            48  start time, s               double
 *    16  sizeof TrebModel   uint32            56  broken (0/1)                uint32
 *    20  sizeof TrebShot    uint32            60  stopped (0/1)               uint32
 *    24  sizeof TrebStep    uint32            64  the FMU's token (GUID)      48 bytes, NUL
 *    28  FMI layer's state  uint32 (TREB_S_*)                                  padded
 *
 * The checksum is 64-bit FNV-1a over every byte of the state, its own 8 counted as 0. It
 * finds accidental corruption; the checks behind it stop a forged state too. */
#ifndef TREB_STATE_H
#define TREB_STATE_H

#include <stddef.h>

#include "treb_model.h"

#define TREB_STATE_MAGIC "TREBSTAT"
#define TREB_STATE_FORMAT 1u
#define TREB_STATE_HEAD 112

/* The FMI layer's states. ERROR: a call failed; only reads (for diagnosis), the FMU state
 * functions, Terminate, Reset and Free are allowed. STOPPED: a step reached TREB_HORIZON. */
enum { TREB_S_INSTANTIATED, TREB_S_INIT, TREB_S_STEP, TREB_S_EVENT, TREB_S_CONTINUOUS,
       TREB_S_TERMINATED, TREB_S_ERROR, TREB_S_STOPPED, TREB_NSTATES };

/* The state's name in messages ("error", "stopped at the horizon", ...). */
const char *treb_state_name(int state);

typedef struct TrebSaved TrebSaved;

/* An instance without its FMI version's callbacks. broken: an error happened, the outputs are
 * no longer computed (reads give the last values) until a reset or a restored state.
 * stopped: a step reached TREB_HORIZON. */
typedef struct {
    int state, broken, stopped;
    double start_time;  /* s (FMI 2; FMI 3 keeps it in m.time until initialisation) */
    TrebModel m;
    TrebSaved *saved;   /* the FMU states this instance made and has not freed */
} TrebCore;

void treb_core_new(TrebCore *k, int cosim);
void treb_core_free(TrebCore *k);   /* the model and every FMU state left */
void treb_core_reset(TrebCore *k);  /* as instantiated; the FMU states stay the host's */

/* Each returns 0, or -1 with the reason in msg (TREB_MSG bytes). fmi: 2 or 3. */
int treb_core_get_state(TrebCore *k, void **state, char *msg);
int treb_core_set_state(TrebCore *k, const void *state, char *msg);
int treb_core_free_state(TrebCore *k, void **state, char *msg);
int treb_core_state_size(TrebCore *k, const void *state, size_t *size, char *msg);
int treb_core_serialize(TrebCore *k, const void *state, int fmi, unsigned char *buf,
                        size_t size, char *msg);
int treb_core_deserialize(TrebCore *k, int fmi, const unsigned char *buf, size_t size,
                          void **state, char *msg);

#endif
