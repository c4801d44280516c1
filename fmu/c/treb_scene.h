/* The scene of the FMU's parameter values, checked as model/scene.py checks a scene file;
 * a refusal names the key ("FMU parameters: [engine] m: = -1: must be a positive mass in
 * kg"). Hand-written glue: the rules are those of Scene.from_dict and
 * trebuchet.fmu.interface.scene_from_parameters. */
#ifndef TREB_SCENE_H
#define TREB_SCENE_H

#include "treb_shot.h"

/* values: every variable's value by value reference (treb_variables.h), enumerations and
 * booleans as numbers. Returns 0, or -1 with the message in msg (TREB_MSG bytes). */
int treb_scene_from_values(const double *values, TrebScene *sc, char *msg);

/* One parameter's value on its own (where it is set): a number in the range
 * modelDescription.xml declares (an Enumeration's choices), and not below the smallest
 * length, mass or gravity the FMU takes (treb_scene.c). 0, or -1 with the message in msg. */
int treb_parameter_check(int vr, double value, char *msg);

#endif
