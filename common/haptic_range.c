/* haptic_range.c - the clamp rule of a focus's safe range (haptic_table.h,
 * docs/table-format.md "Range section"): what hapticd plays for a level
 * outside it. In the reader's library: the device links it. */
#include "haptic_table.h"

#include <math.h>

double haptic_gain_range_clamp(const haptic_gain_range *r, double gain)
{
    /* The top: a relative margin under hi, and never hi itself (a hi so
     * small that the margin rounds away gets the next double below). */
    const double top = fmin(r->hi * (1.0 - HAPTIC_GAIN_RANGE_TOP_MARGIN), nextafter(r->hi, 0.0));
    const double g = gain > r->lo ? gain : r->lo; /* a NaN asks for the bottom */
    return g < top ? g : top;                     /* lo >= hi: the top, below lo */
}

void haptic_gain_range_intersect(haptic_gain_range *acc, const haptic_gain_range *r)
{
    if (r->lo > acc->lo)
        acc->lo = r->lo;
    if (r->hi < acc->hi)
        acc->hi = r->hi;
}
