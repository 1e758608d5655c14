/*
 * roots.h: when an event function has crossed zero, the one rule of every loop here that
 * finds roots by the sides of the event functions: the DOPRI5 pair (dopri5.c) between its
 * steps, and an FMI importer's Model Exchange steps (model_machine_crossed). CVODE and
 * ARKODE find their roots themselves, with the same directions.
 *
 * A side is +1 or -1 (0: none yet). Exactly on zero, a function keeps the side it came from:
 * reaching zero in the watched direction is the crossing (a located root, an importer's
 * step, can land exactly on it).
 */
#ifndef IG_ROOTS_H
#define IG_ROOTS_H

/* The side of a value: +1, -1, or 0 exactly on zero. */
static inline double ig_side_of(double g)
{
    return g > 0.0 ? 1.0 : (g < 0.0 ? -1.0 : 0.0);
}

/* The side to keep after the value g: its own, or the one kept before when g is exactly 0. */
static inline double ig_side_after(double side, double g)
{
    return g != 0.0 ? ig_side_of(g) : side;
}

/* Whether an event with the stored side crossed to the value g in `direction` (+1 rising,
 * -1 falling, 0 either way): it left its side (an exact 0 counts) the way it is watched. An
 * event with no side yet has not crossed. */
static inline int ig_crossed(double side, double g, int direction)
{
    if (side == 0.0 || ig_side_of(g) == side) return 0;
    return direction == 0 || direction == -side;
}

#endif /* IG_ROOTS_H */
