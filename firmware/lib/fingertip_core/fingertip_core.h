// Device logic of the fingertip firmware, Arduino-free (docs/protocol.md sections 5 and 6).
// One include for all; named after the library folder so that Arduino and PlatformIO find the
// library by it. Depends on fingertip_protocol (the wire codec).
#ifndef FINGERTIP_CORE_H
#define FINGERTIP_CORE_H

#include "device.h"
#include "hal.h"

#endif  // FINGERTIP_CORE_H
