/* Raw bytes to the reader: must never crash, overread or accept garbage. */
#include "fuzz_target.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    exercise_table(data, size);
    return 0;
}
