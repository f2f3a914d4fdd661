// Wire protocol v1 of the fingertip, Arduino-free (docs/protocol.md). One include for all;
// named after the library folder so that Arduino and PlatformIO find the library by it.
#ifndef FINGERTIP_PROTOCOL_H
#define FINGERTIP_PROTOCOL_H

#include "cobs.h"
#include "crc16.h"
#include "encoder.h"
#include "int24.h"
#include "protocol.h"
#include "receiver.h"

#endif  // FINGERTIP_PROTOCOL_H
