// PlatformIO test suite (pio test -e native): the same source as `make test-native`.
#include "../../test_protocol.cpp"
