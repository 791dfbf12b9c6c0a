/* The fuzzer rarely forges a CRC-32, so this harness re-makes the trailer
 * and the file_size field of each input: mutations then reach the field,
 * layout and Gram checks behind the integrity check. */
#include "fuzz_target.h"

#include <zlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 128 || size > (1u << 20))
        return 0;
    uint8_t *b = malloc(size);
    memcpy(b, data, size);
    for (int i = 0; i < 8; i++)
        b[40 + i] = (uint8_t)((uint64_t)size >> (8 * i));
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), b, (uInt)(size - 4));
    for (int i = 0; i < 4; i++)
        b[size - 4 + i] = (uint8_t)(crc >> (8 * i));
    exercise_table(b, size);
    free(b);
    return 0;
}
