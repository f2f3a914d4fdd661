// COBS (Consistent Overhead Byte Stuffing), as in docs/protocol.md section 2.2.
// Neither function writes the 0x00 delimiter; the caller frames.
#ifndef FINGERTIP_PROTOCOL_COBS_H
#define FINGERTIP_PROTOCOL_COBS_H

#include <stddef.h>
#include <stdint.h>

namespace ftp {

// Worst-case encoded size of len bytes: one code byte per started 254-byte block, and one
// for an empty input.
inline size_t cobsMaxEncoded(size_t len) { return len + len / 254 + 1; }

// Encodes len bytes of src into dst (capacity cap). Returns the encoded length, or 0 if cap is
// too small (a valid encoding is never 0 bytes long).
// In place: dst == src - 1 is allowed when len <= 254 (every byte moves by exactly one, and is
// read before it is overwritten), which lets a frame be built at buf + 1 and encoded into buf.
size_t cobsEncode(const uint8_t* src, size_t len, uint8_t* dst, size_t cap);

// Decodes len encoded bytes (delimiter excluded) from src into dst (capacity cap).
// Returns true and sets *out_len on success; false on a COBS error (code byte 0x00, a block
// running past the end, no bytes at all) or when the result would not fit into cap.
// In place: dst == src is allowed (the write position never passes the read position).
bool cobsDecode(const uint8_t* src, size_t len, uint8_t* dst, size_t cap, size_t* out_len);

}  // namespace ftp

#endif  // FINGERTIP_PROTOCOL_COBS_H
