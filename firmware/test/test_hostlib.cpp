// Native tests of the host library (hostlib/: the device on a simulated board, C API), with
// the sanitizers: the code Python drives through ctypes, run here where ASan and UBSan see it.
#include "doctest_setup.h"  // doctest with its main (or PlatformIO's)

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "fingertip_device.h"
#include "fingertip_protocol.h"

namespace {

struct Inputs {
  std::vector<uint64_t> calls;
  double value = 1000.0;
  bool fail = false;
};

int inputs(void* ctx, uint64_t t_us, double* out, uint8_t n) {
  Inputs* in = static_cast<Inputs*>(ctx);
  in->calls.push_back(t_us);
  for (uint8_t i = 0; i < n; ++i) out[i] = in->value * (i + 1);
  return in->fail ? 1 : 0;
}

// Device frames in the output buffer: (type, payload); the buffer is emptied.
std::vector<std::pair<uint8_t, std::vector<uint8_t>>> take(FtdDevice* d) {
  std::vector<std::pair<uint8_t, std::vector<uint8_t>>> out;
  const uint8_t* p = ftd_tx_data(d);
  const size_t n = ftd_tx_size(d);
  std::vector<uint8_t> enc;
  for (size_t i = 0; i < n; ++i) {
    if (p[i] != 0) {
      enc.push_back(p[i]);
      continue;
    }
    if (enc.empty()) continue;
    std::vector<uint8_t> f(enc.size());
    size_t len = 0;
    REQUIRE(ftp::cobsDecode(enc.data(), enc.size(), f.data(), f.size(), &len));
    REQUIRE(len >= ftp::kMinFrame);
    REQUIRE(ftp::crc16(f.data(), len - 2) == (f[len - 2] | (f[len - 1] << 8)));
    out.emplace_back(f[0], std::vector<uint8_t>(f.begin() + 3, f.begin() + len - 2));
    enc.clear();
  }
  ftd_tx_clear(d);
  return out;
}

// A command with an empty payload, as wire bytes.
std::vector<uint8_t> bare(ftp::MsgType type, uint16_t rid) {
  uint8_t f[5] = {static_cast<uint8_t>(type), static_cast<uint8_t>(rid),
                  static_cast<uint8_t>(rid >> 8), 0, 0};
  const uint16_t crc = ftp::crc16(f, 3);
  f[3] = static_cast<uint8_t>(crc);
  f[4] = static_cast<uint8_t>(crc >> 8);
  std::vector<uint8_t> w(ftp::cobsMaxEncoded(5) + 1);
  w.resize(ftp::cobsEncode(f, 5, w.data(), w.size()));
  w.push_back(0);
  return w;
}

int64_t send(FtdDevice* d, ftp::MsgType type, uint16_t rid) {
  const std::vector<uint8_t> w = bare(type, rid);
  return ftd_receive(d, w.data(), w.size());
}

const uint8_t kSample = static_cast<uint8_t>(ftp::MsgType::Sample);

}  // namespace

TEST_CASE("hostlib: boot, commands, event-driven streaming, inputs only on reads") {
  FtdDevice* d = ftd_create(4, 0, 1);
  REQUIRE(d != nullptr);
  Inputs in;
  ftd_set_inputs(d, inputs, &in);
  const int64_t n = ftd_boot(d, 0);
  CHECK(n == static_cast<int64_t>(ftd_tx_size(d)));
  CHECK(ftd_tx_data(d)[0] == 0);  // the lone delimiter first
  auto boot = take(d);
  REQUIRE(boot.size() == 2);
  CHECK(boot[0].first == static_cast<uint8_t>(ftp::MsgType::Info));
  CHECK(boot[1].first == static_cast<uint8_t>(ftp::MsgType::Log));
  CHECK(ftd_next_due(d) == 50000);  // 4 periods of settling at 80 SPS

  CHECK(send(d, ftp::MsgType::Start, 1) > 0);
  CHECK(take(d).size() == 1);  // ACK
  CHECK(ftd_advance(d, 1000000) > 0);
  int samples = 0;
  int stats = 0;
  for (const auto& m : take(d)) {
    samples += m.first == kSample;
    stats += m.first == static_cast<uint8_t>(ftp::MsgType::Stats);
  }
  CHECK(samples == 77);
  CHECK(stats == 1);
  REQUIRE(in.calls.size() == 77u);
  CHECK(in.calls.front() == 50000u);
  CHECK(in.calls.back() == 1000000u);
  CHECK(ftd_now(d) == 1000000u);

  FtdState s;
  ftd_state(d, &s);
  CHECK(s.streaming == 1);
  CHECK(s.stats[3] == 0);  // no saturation
  CHECK(s.stats[9] == 0);  // longest loop: polled only when due

  // Dead chips: timeouts at the deadline, no inputs asked for when none is ready.
  CHECK(ftd_set_dead_mask(d, 0x10) == FTD_E_ARGUMENT);
  CHECK(ftd_set_dead_mask(d, 0xF) == FTD_OK);
  CHECK(ftd_dead_mask(d) == 0xF);
  const size_t calls = in.calls.size();
  ftd_advance(d, 1100000);
  CHECK(in.calls.size() == calls);
  auto dead = take(d);
  REQUIRE(!dead.empty());
  CHECK(dead.back().first == kSample);
  CHECK((dead.back().second[5] | (dead.back().second[6] << 8)) == 0xF);  // timeout mask

  // Inputs that fail or are NaN stop the call with an error, then the device runs on.
  ftd_set_dead_mask(d, 0);
  in.fail = true;
  CHECK(ftd_advance(d, 1200000) == FTD_E_INPUTS);
  in.fail = false;
  in.value = NAN;
  CHECK(ftd_advance(d, 1300000) == FTD_E_NAN);
  in.value = 5.0;
  ftd_tx_clear(d);
  CHECK(ftd_advance(d, 1400000) > 0);

  ftd_reset(d);
  CHECK(ftd_now(d) == 0u);
  CHECK(ftd_next_due(d) == -1);
  CHECK(ftd_dead_mask(d) == 0);
  ftd_destroy(d);
}

TEST_CASE("hostlib: constants and STATS names") {
  int64_t v = 0;
  CHECK(ftd_constant("max_frame", &v) == 0);
  CHECK(v == ftp::kMaxFrame);
  CHECK(ftd_constant("no_such_constant", &v) == -1);
  int i = 0;
  for (; ftd_constant_name(i) != nullptr; ++i) {
    CHECK(ftd_constant(ftd_constant_name(i), &v) == 0);
  }
  CHECK(i > 40);
  CHECK(std::string(ftd_stats_field(0)) == "timestamp_us");
  CHECK(std::string(ftd_stats_field(9)) == "longest_loop_us");
  CHECK(ftd_stats_field(10) == nullptr);
  CHECK(ftd_create(0, 0, 0) == nullptr);
  CHECK(ftd_create(17, 0, 0) == nullptr);
}
