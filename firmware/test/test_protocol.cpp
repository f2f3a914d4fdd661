// Native tests of the Arduino-free protocol library against the shared vectors
// (tests/vectors/protocol_v1.json) plus cases of our own.
//
// Vector file: $FTP_VECTORS if set, else FTP_VECTORS_PATH given by the Makefile.
#include "doctest_setup.h"  // doctest with its main (or PlatformIO's)

#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fingertip_protocol.h"

#ifndef FTP_VECTORS_PATH
#define FTP_VECTORS_PATH ""
#endif

using json = nlohmann::json;
using Bytes = std::vector<uint8_t>;

namespace {

// ---------------------------------------------------------------------------------------------
// Helpers

Bytes fromHex(const std::string& hex) {
  REQUIRE_MESSAGE(hex.size() % 2 == 0, "odd hex length: " << hex);
  Bytes out;
  for (size_t i = 0; i < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

std::string toHex(const uint8_t* p, size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (size_t i = 0; i < n; ++i) {
    s += digits[p[i] >> 4];
    s += digits[p[i] & 0xF];
  }
  return s;
}

std::string toHex(const Bytes& b) { return toHex(b.data(), b.size()); }

Bytes asciiBytes(const std::string& s) { return Bytes(s.begin(), s.end()); }

std::string vectorsPath() {
  const char* env = std::getenv("FTP_VECTORS");
  return (env != nullptr && *env != '\0') ? env : FTP_VECTORS_PATH;
}

// Parsed once; a missing or broken file fails every test that needs it, loudly.
const json& vectors() {
  static const json j = [] {
    std::ifstream f(vectorsPath());
    if (!f) {
      return json();
    }
    return json::parse(f, nullptr, /*allow_exceptions=*/false);
  }();
  REQUIRE_MESSAGE(j.is_object(),
                  "cannot read the vector file '" << vectorsPath()
                                                  << "' (set FTP_VECTORS or FTP_VECTORS_PATH)");
  return j;
}

const json& section(const char* name) {
  const json& v = vectors();
  REQUIRE_MESSAGE((v.contains(name) && v.at(name).is_array()),
                  "vector file has no array '" << name << "'");
  const json& s = v.at(name);
  REQUIRE_MESSAGE(!s.empty(), "vector section '" << name << "' is empty");
  return s;
}

ftp::MsgType commandType(const std::string& name) {
  static const std::map<std::string, ftp::MsgType> m = {
      {"ping", ftp::MsgType::Ping},
      {"get_info", ftp::MsgType::GetInfo},
      {"start", ftp::MsgType::Start},
      {"stop", ftp::MsgType::Stop},
      {"tare", ftp::MsgType::Tare},
      {"set_rate", ftp::MsgType::SetRate},
      {"set_gain", ftp::MsgType::SetGain},
      {"reset_counters", ftp::MsgType::ResetCounters},
      {"set_power", ftp::MsgType::SetPower},
      {"get_stats", ftp::MsgType::GetStats},
      {"set_tare_offsets", ftp::MsgType::SetTareOffsets},
  };
  auto it = m.find(name);
  REQUIRE_MESSAGE(it != m.end(), "unknown command name in vectors: " << name);
  return it->second;
}

ftp::RxError rxError(const std::string& name) {
  static const std::map<std::string, ftp::RxError> m = {
      {"empty", ftp::RxError::Empty},
      {"too_long", ftp::RxError::TooLong},
      {"cobs", ftp::RxError::Cobs},
      {"too_short", ftp::RxError::TooShort},
      {"crc", ftp::RxError::Crc},
      {"unknown_type", ftp::RxError::UnknownType},
      {"bad_payload", ftp::RxError::BadPayload},
  };
  auto it = m.find(name);
  REQUIRE_MESSAGE(it != m.end(), "unknown error kind in vectors: " << name);
  return it->second;
}

int asInt(ftp::RxError e) { return static_cast<int>(e); }
int asInt(ftp::NackError e) { return static_cast<int>(e); }
int asInt(ftp::MsgType t) { return static_cast<int>(t); }

// Feeds bytes one at a time; returns every result with the index of the byte that ended it.
struct Fed {
  std::vector<ftp::RxResult> results;
  std::vector<size_t> at;
};

Fed feedBytes(ftp::CommandReceiver& rx, const Bytes& bytes) {
  Fed fed;
  for (size_t i = 0; i < bytes.size(); ++i) {
    ftp::RxResult r;
    if (rx.feed(bytes[i], r)) {
      fed.results.push_back(r);
      fed.at.push_back(i);
    }
  }
  return fed;
}

// Feeds through the chunk interface.
std::vector<ftp::RxResult> feedChunk(ftp::CommandReceiver& rx, const Bytes& bytes) {
  std::vector<ftp::RxResult> out;
  const uint8_t* p = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {
    size_t used = 0;
    ftp::RxResult r;
    const bool done = rx.feed(p, left, used, r);
    REQUIRE(used > 0);
    REQUIRE(used <= left);
    if (done) {
      out.push_back(r);
    }
    p += used;
    left -= used;
  }
  return out;
}

bool sameResult(const ftp::RxResult& a, const ftp::RxResult& b) {
  return a.error == b.error && a.nack == b.nack && a.command.type == b.command.type &&
         a.command.request_id == b.command.request_id &&
         a.command.channel_mask == b.command.channel_mask &&
         a.command.samples == b.command.samples && a.command.rate_sps == b.command.rate_sps &&
         a.command.decimation == b.command.decimation && a.command.gain == b.command.gain &&
         a.command.on == b.command.on &&
         memcmp(a.command.offsets, b.command.offsets, sizeof(a.command.offsets)) == 0;
}

uint32_t counterSum(const ftp::RxCounters& c) {
  return c.commands_ok + c.empty_frames + c.overflows + c.framing_errors + c.crc_errors +
         c.rejected;
}

// Packs and frames a command the way docs/protocol.md says, for cases the vectors lack.
Bytes commandWire(uint8_t type, uint16_t request_id, const Bytes& payload) {
  Bytes frame = {type, static_cast<uint8_t>(request_id), static_cast<uint8_t>(request_id >> 8)};
  frame.insert(frame.end(), payload.begin(), payload.end());
  const uint16_t crc = ftp::crc16(frame.data(), frame.size());
  frame.push_back(static_cast<uint8_t>(crc));
  frame.push_back(static_cast<uint8_t>(crc >> 8));
  Bytes out(ftp::cobsMaxEncoded(frame.size()) + 1);
  const size_t n = ftp::cobsEncode(frame.data(), frame.size(), out.data(), out.size());
  REQUIRE(n > 0);
  out.resize(n);
  out.push_back(0x00);
  return out;
}

Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) {
    out.insert(out.end(), p.begin(), p.end());
  }
  return out;
}

// Builds a device message from its vector description and encodes it with seq = message.seq.
Bytes encodeDevice(const json& m) {
  ftp::Encoder enc;
  enc.setSeq(m.at("seq").get<uint16_t>());
  uint8_t buf[ftp::kMaxWire];
  memset(buf, 0xA5, sizeof(buf));
  const std::string type = m.at("type").get<std::string>();
  size_t n = 0;
  if (type == "sample") {
    ftp::Sample s{};
    const json& values = m.at("values");
    REQUIRE(values.size() <= ftp::kMaxChannels);
    s.timestamp_us = m.at("timestamp_us").get<uint32_t>();
    s.channels = static_cast<uint8_t>(values.size());
    s.timeout_mask = m.at("timeout_mask").get<uint16_t>();
    s.saturation_mask = m.at("saturation_mask").get<uint16_t>();
    for (size_t i = 0; i < values.size(); ++i) {
      s.values[i] = values[i].get<int32_t>();
    }
    n = enc.encodeSample(s, buf, sizeof(buf));
  } else if (type == "info") {
    ftp::Info s{};
    const json& offsets = m.at("tare_offsets");
    REQUIRE(offsets.size() <= ftp::kMaxChannels);
    s.protocol_major = m.at("protocol_major").get<uint8_t>();
    s.protocol_minor = m.at("protocol_minor").get<uint8_t>();
    for (size_t i = 0; i < 3; ++i) {
      s.firmware_version[i] = m.at("firmware_version").at(i).get<uint8_t>();
    }
    s.build_id = m.at("build_id").get<uint32_t>();
    s.reason = m.at("reason").get<uint8_t>();
    s.reset_cause = m.at("reset_cause").get<uint8_t>();
    s.channels = m.at("channels").get<uint8_t>();
    REQUIRE(s.channels == offsets.size());
    s.rate_sps = m.at("rate_sps").get<uint8_t>();
    s.decimation = m.at("decimation").get<uint8_t>();
    s.gain = m.at("gain").get<uint8_t>();
    s.flags = m.at("flags").get<uint8_t>();
    s.tare_mask = m.at("tare_mask").get<uint16_t>();
    for (size_t i = 0; i < offsets.size(); ++i) {
      s.tare_offsets[i] = offsets[i].get<int32_t>();
    }
    n = enc.encodeInfo(s, buf, sizeof(buf));
  } else if (type == "stats") {
    ftp::Stats s{};
    s.timestamp_us = m.at("timestamp_us").get<uint32_t>();
    s.frames_sent = m.at("frames_sent").get<uint32_t>();
    s.read_timeouts = m.at("read_timeouts").get<uint32_t>();
    s.saturations = m.at("saturations").get<uint32_t>();
    s.command_errors = m.at("command_errors").get<uint32_t>();
    s.rx_overflows = m.at("rx_overflows").get<uint32_t>();
    s.rx_crc_errors = m.at("rx_crc_errors").get<uint32_t>();
    s.rx_framing_errors = m.at("rx_framing_errors").get<uint32_t>();
    s.tx_overruns = m.at("tx_overruns").get<uint32_t>();
    s.longest_loop_us = m.at("longest_loop_us").get<uint32_t>();
    n = enc.encodeStats(s, buf, sizeof(buf));
  } else if (type == "ack") {
    n = enc.encodeAck(m.at("request_id").get<uint16_t>(),
                      static_cast<ftp::MsgType>(m.at("command").get<uint8_t>()), buf,
                      sizeof(buf));
  } else if (type == "nack") {
    n = enc.encodeNack(m.at("request_id").get<uint16_t>(),
                       static_cast<ftp::MsgType>(m.at("command").get<uint8_t>()),
                       static_cast<ftp::NackError>(m.at("error").get<uint8_t>()), buf,
                       sizeof(buf));
  } else if (type == "log") {
    const std::string text = m.at("text").get<std::string>();
    n = enc.encodeLog(static_cast<ftp::LogLevel>(m.at("level").get<uint8_t>()), text.data(),
                      text.size(), buf, sizeof(buf));
  } else {
    FAIL("unknown device message type in vectors: " << type);
  }
  REQUIRE_MESSAGE(n > 0, "encoder refused " << m.dump());
  REQUIRE(n <= sizeof(buf));
  // One frame, seq consumed once.
  CHECK(enc.seq() == static_cast<uint16_t>(m.at("seq").get<uint16_t>() + 1));
  return Bytes(buf, buf + n);
}

// Decodes a vector's wire bytes (delimiter excluded) with the library, for header fields.
Bytes decodeWire(const Bytes& wire) {
  REQUIRE(!wire.empty());
  REQUIRE(wire.back() == 0x00);
  Bytes out(wire.size());
  size_t n = 0;
  REQUIRE(ftp::cobsDecode(wire.data(), wire.size() - 1, out.data(), out.size(), &n));
  out.resize(n);
  return out;
}

}  // namespace

// =============================================================================================
// The shared vectors

TEST_CASE("vector file: version and limits agree with the constants") {
  const json& v = vectors();
  CHECK(v.at("protocol").at("major").get<int>() == ftp::kProtocolMajor);
  CHECK(v.at("protocol").at("minor").get<int>() == ftp::kProtocolMinor);
  const json& l = v.at("limits");
  CHECK(l.at("max_frame").get<int>() == ftp::kMaxFrame);
  CHECK(l.at("max_encoded").get<int>() == ftp::kMaxEncoded);
  CHECK(l.at("max_channels").get<int>() == ftp::kMaxChannels);
  CHECK(l.at("max_log_text").get<int>() == ftp::kMaxLogText);
  CHECK(ftp::kMaxEncoded == ftp::cobsMaxEncoded(ftp::kMaxFrame));
}

TEST_CASE("vector file: the shared constants agree with the headers") {
  // tests/vectors/protocol_v1.json "constants" is the one list both sides are checked against
  // (tests/protocol/test_constants.py does the Python side and the host library).
  const json& c = vectors().at("constants");
  CHECK(c.at("protocol_major").get<int>() == ftp::kProtocolMajor);
  CHECK(c.at("protocol_minor").get<int>() == ftp::kProtocolMinor);
  CHECK(c.at("header_size").get<int>() == ftp::kHeaderSize);
  CHECK(c.at("crc_size").get<int>() == ftp::kCrcSize);
  CHECK(c.at("min_frame").get<int>() == ftp::kMinFrame);
  CHECK(c.at("max_frame").get<int>() == ftp::kMaxFrame);
  CHECK(c.at("max_encoded").get<int>() == ftp::kMaxEncoded);
  CHECK(c.at("max_channels").get<int>() == ftp::kMaxChannels);
  CHECK(c.at("max_log_text").get<int>() == ftp::kMaxLogText);
  CHECK(c.at("max_tare_samples").get<int>() == ftp::kMaxTareSamples);
  CHECK(c.at("int24_min").get<int32_t>() == ftp::kInt24Min);
  CHECK(c.at("int24_max").get<int32_t>() == ftp::kInt24Max);
  CHECK(c.at("sample_payload_fixed").get<int>() == ftp::kSamplePayloadFixed);
  CHECK(c.at("info_payload_fixed").get<int>() == ftp::kInfoPayloadFixed);
  CHECK(c.at("stats_payload").get<int>() == ftp::kStatsPayload);
  CHECK(c.at("ack_payload").get<int>() == ftp::kAckPayload);
  CHECK(c.at("nack_payload").get<int>() == ftp::kNackPayload);
  CHECK(c.at("flag_streaming").get<int>() == ftp::kFlagStreaming);
  CHECK(c.at("flag_powered_down").get<int>() == ftp::kFlagPoweredDown);
  CHECK(c.at("flag_tare_in_progress").get<int>() == ftp::kFlagTareInProgress);
  CHECK(c.at("info_reason_request").get<int>() == ftp::kInfoReasonRequest);
  CHECK(c.at("info_reason_boot").get<int>() == ftp::kInfoReasonBoot);

  const json& t = c.at("message_types");
  CHECK(t.size() == 17u);
  CHECK(t.at("ping").get<int>() == static_cast<int>(ftp::MsgType::Ping));
  CHECK(t.at("get_info").get<int>() == static_cast<int>(ftp::MsgType::GetInfo));
  CHECK(t.at("start").get<int>() == static_cast<int>(ftp::MsgType::Start));
  CHECK(t.at("stop").get<int>() == static_cast<int>(ftp::MsgType::Stop));
  CHECK(t.at("tare").get<int>() == static_cast<int>(ftp::MsgType::Tare));
  CHECK(t.at("set_rate").get<int>() == static_cast<int>(ftp::MsgType::SetRate));
  CHECK(t.at("set_gain").get<int>() == static_cast<int>(ftp::MsgType::SetGain));
  CHECK(t.at("reset_counters").get<int>() == static_cast<int>(ftp::MsgType::ResetCounters));
  CHECK(t.at("set_power").get<int>() == static_cast<int>(ftp::MsgType::SetPower));
  CHECK(t.at("get_stats").get<int>() == static_cast<int>(ftp::MsgType::GetStats));
  CHECK(t.at("set_tare_offsets").get<int>() == static_cast<int>(ftp::MsgType::SetTareOffsets));
  CHECK(t.at("sample").get<int>() == static_cast<int>(ftp::MsgType::Sample));
  CHECK(t.at("info").get<int>() == static_cast<int>(ftp::MsgType::Info));
  CHECK(t.at("stats").get<int>() == static_cast<int>(ftp::MsgType::Stats));
  CHECK(t.at("ack").get<int>() == static_cast<int>(ftp::MsgType::Ack));
  CHECK(t.at("nack").get<int>() == static_cast<int>(ftp::MsgType::Nack));
  CHECK(t.at("log").get<int>() == static_cast<int>(ftp::MsgType::Log));

  const json& e = c.at("nack_errors");
  CHECK(e.size() == 6u);
  CHECK(e.at("unknown_command").get<int>() == static_cast<int>(ftp::NackError::UnknownCommand));
  CHECK(e.at("bad_length").get<int>() == static_cast<int>(ftp::NackError::BadLength));
  CHECK(e.at("bad_argument").get<int>() == static_cast<int>(ftp::NackError::BadArgument));
  CHECK(e.at("busy").get<int>() == static_cast<int>(ftp::NackError::Busy));
  CHECK(e.at("chip_timeout").get<int>() == static_cast<int>(ftp::NackError::ChipTimeout));
  CHECK(e.at("powered_down").get<int>() == static_cast<int>(ftp::NackError::PoweredDown));

  // STATS counter names in wire order: the X-list the struct and the encoder are made from.
  std::vector<std::string> names;
#define FTP_TEST_NAME(name) names.push_back(#name);
  FTP_STATS_FIELDS(FTP_TEST_NAME)
#undef FTP_TEST_NAME
  CHECK(names == c.at("stats_fields").get<std::vector<std::string>>());
  CHECK(sizeof(ftp::Stats) == 4u * names.size());
}

TEST_CASE("vectors: crc") {
  int n = 0;
  for (const json& c : section("crc")) {
    Bytes data = c.contains("ascii") ? asciiBytes(c["ascii"].get<std::string>())
                                     : fromHex(c.at("hex").get<std::string>());
    INFO("crc vector " << c.dump());
    CHECK(ftp::crc16(data.data(), data.size()) == c.at("crc").get<uint16_t>());
    // Piecewise CRC continues where the first part stopped.
    const size_t half = data.size() / 2;
    const uint16_t first = ftp::crc16(data.data(), half);
    CHECK(ftp::crc16(data.data() + half, data.size() - half, first) ==
          c.at("crc").get<uint16_t>());
    ++n;
  }
  CHECK(n >= 3);
}

TEST_CASE("vectors: cobs encode and decode") {
  int n = 0;
  for (const json& c : section("cobs")) {
    const Bytes decoded = fromHex(c.at("decoded").get<std::string>());
    const Bytes encoded = fromHex(c.at("encoded").get<std::string>());
    INFO("cobs vector decoded=" << c.at("decoded").get<std::string>());

    Bytes out(ftp::cobsMaxEncoded(decoded.size()));
    const size_t ne = ftp::cobsEncode(decoded.data(), decoded.size(), out.data(), out.size());
    out.resize(ne);
    CHECK(toHex(out) == toHex(encoded));
    // The exact size is also the smallest capacity that works.
    if (encoded.size() > 0) {
      Bytes small(encoded.size() - 1);
      CHECK(ftp::cobsEncode(decoded.data(), decoded.size(), small.data(), small.size()) == 0);
    }

    Bytes back(encoded.size());
    size_t nd = 12345;
    REQUIRE(ftp::cobsDecode(encoded.data(), encoded.size(), back.data(), back.size(), &nd));
    back.resize(nd);
    CHECK(toHex(back) == toHex(decoded));

    // In place, as the receiver does it.
    Bytes inplace = encoded;
    nd = 12345;
    REQUIRE(ftp::cobsDecode(inplace.data(), inplace.size(), inplace.data(), inplace.size(), &nd));
    CHECK(toHex(inplace.data(), nd) == toHex(decoded));

    // In place encode (dst = src - 1) holds up to 254 bytes, as the encoder relies on.
    if (decoded.size() <= 254) {
      Bytes buf(ftp::cobsMaxEncoded(decoded.size()));  // 254 bytes end in "ff .. 01": +2
      std::copy(decoded.begin(), decoded.end(), buf.begin() + 1);
      const size_t ni = ftp::cobsEncode(buf.data() + 1, decoded.size(), buf.data(), buf.size());
      CHECK(toHex(buf.data(), ni) == toHex(encoded));
    }
    ++n;
  }
  CHECK(n >= 11);
}

TEST_CASE("vectors: device frames encode to the exact bytes") {
  int n = 0;
  for (const json& f : section("frames")) {
    if (f.at("direction") != "device") {
      continue;
    }
    INFO("frame " << f.at("name").get<std::string>());
    const Bytes wire = encodeDevice(f.at("message"));
    CHECK(toHex(wire) == f.at("hex").get<std::string>());
    ++n;
  }
  MESSAGE("device frames checked: " << n);
  CHECK(n > 0);
}

TEST_CASE("vectors: host frames decode to every field") {
  int n = 0;
  for (const json& f : section("frames")) {
    if (f.at("direction") != "host") {
      continue;
    }
    const std::string name = f.at("name").get<std::string>();
    INFO("frame " << name);
    const json& m = f.at("message");
    const Bytes wire = fromHex(f.at("hex").get<std::string>());

    ftp::CommandReceiver rx;
    const Fed fed = feedBytes(rx, wire);
    REQUIRE(fed.results.size() == 1);
    CHECK(fed.at[0] == wire.size() - 1);  // the verdict comes with the delimiter, not before
    const ftp::RxResult& r = fed.results[0];
    CHECK(asInt(r.error) == asInt(ftp::RxError::None));
    CHECK(asInt(r.nack) == asInt(ftp::NackError::None));
    const ftp::Command& c = r.command;
    CHECK(asInt(c.type) == asInt(commandType(m.at("type").get<std::string>())));
    CHECK(c.request_id == m.at("request_id").get<uint16_t>());
    // Arguments a type does not have must read as 0.
    CHECK(c.channel_mask == m.value("channel_mask", 0u));
    CHECK(c.samples == m.value("samples", 0u));
    CHECK(c.rate_sps == m.value("rate_sps", 0u));
    CHECK(c.decimation == m.value("decimation", 0u));
    CHECK(c.gain == m.value("gain", 0u));
    CHECK(c.on == m.value("on", 0u));
    for (int ch = 0; ch < ftp::kMaxChannels; ++ch) {
      const int32_t want = m.contains("offsets") ? m.at("offsets").at(ch).get<int32_t>() : 0;
      CHECK(c.offsets[ch] == want);
    }
    CHECK(rx.counters().commands_ok == 1);
    CHECK(counterSum(rx.counters()) == 1);
    ++n;
  }
  MESSAGE("host frames checked: " << n);
  CHECK(n > 0);
}

TEST_CASE("vectors: invalid input gives the named error, NACK code and echo") {
  int n = 0;
  int skipped = 0;
  for (const json& v : section("invalid")) {
    const std::string dir = v.at("direction").get<std::string>();
    if (dir == "device") {
      ++skipped;  // for the host's decoder
      continue;
    }
    REQUIRE_MESSAGE((dir == "host" || dir == "any"), "unknown direction " << dir);
    const std::string name = v.at("name").get<std::string>();
    INFO("invalid " << name << ": " << v.value("note", ""));
    const Bytes wire = fromHex(v.at("hex").get<std::string>());
    const ftp::RxError want = rxError(v.at("error").get<std::string>());

    ftp::CommandReceiver rx;
    const Fed fed = feedBytes(rx, wire);
    REQUIRE(fed.results.size() == 1);
    CHECK(fed.at[0] == wire.size() - 1);
    const ftp::RxResult& r = fed.results[0];
    CHECK(asInt(r.error) == asInt(want));
    CHECK(counterSum(rx.counters()) == 1);

    if (v.contains("nack_error")) {
      CHECK(asInt(r.nack) == v["nack_error"].get<int>());
      // Echo: type and request id as they stand in the (intact) frame.
      const Bytes frame = decodeWire(wire);
      REQUIRE(frame.size() >= 3);
      CHECK(asInt(r.command.type) == frame[0]);
      CHECK(r.command.request_id == (frame[1] | (frame[2] << 8)));
      CHECK(rx.counters().rejected == 1);
    } else {
      CHECK(asInt(r.nack) == asInt(ftp::NackError::None));
    }
    // Where each kind is counted.
    const ftp::RxCounters& k = rx.counters();
    switch (want) {
      case ftp::RxError::Empty: CHECK(k.empty_frames == 1); break;
      case ftp::RxError::TooLong: CHECK(k.overflows == 1); break;
      case ftp::RxError::Cobs:
      case ftp::RxError::TooShort: CHECK(k.framing_errors == 1); break;
      case ftp::RxError::Crc: CHECK(k.crc_errors == 1); break;
      case ftp::RxError::UnknownType:
      case ftp::RxError::BadPayload: CHECK(k.rejected == 1); break;
      default: FAIL("unexpected kind"); break;
    }
    ++n;
  }
  MESSAGE("invalid inputs checked: " << n << ", skipped (device direction): " << skipped);
  CHECK(n > 0);
}

TEST_CASE("vectors: one stream of every host input gives the same verdicts, bytewise or chunked") {
  // Concatenate every host-relevant vector; a receiver must judge each exactly as it did in
  // isolation (nothing leaks from one frame into the next).
  Bytes stream;
  std::vector<ftp::RxResult> expected;
  ftp::RxCounters sum{};  // of the fresh receivers' counters
  auto add = [&](const std::string& hex) {
    const Bytes wire = fromHex(hex);
    ftp::CommandReceiver fresh;
    const Fed fed = feedBytes(fresh, wire);
    REQUIRE(fed.results.size() == 1);
    expected.push_back(fed.results[0]);
    stream.insert(stream.end(), wire.begin(), wire.end());
    sum.commands_ok += fresh.counters().commands_ok;
    sum.empty_frames += fresh.counters().empty_frames;
    sum.overflows += fresh.counters().overflows;
    sum.framing_errors += fresh.counters().framing_errors;
    sum.crc_errors += fresh.counters().crc_errors;
    sum.rejected += fresh.counters().rejected;
  };
  size_t host_frames = 0;
  for (const json& f : section("frames")) {
    if (f.at("direction") == "host") {
      add(f.at("hex").get<std::string>());
      ++host_frames;
    }
  }
  for (const json& v : section("invalid")) {
    if (v.at("direction") != "device") add(v.at("hex").get<std::string>());
  }
  REQUIRE(host_frames > 0);
  REQUIRE(expected.size() > host_frames);

  ftp::CommandReceiver bytewise;
  const Fed fed = feedBytes(bytewise, stream);
  ftp::CommandReceiver chunked;
  const std::vector<ftp::RxResult> chunks = feedChunk(chunked, stream);
  REQUIRE(fed.results.size() == expected.size());
  REQUIRE(chunks.size() == expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    INFO("frame #" << i);
    CHECK(sameResult(fed.results[i], expected[i]));
    CHECK(sameResult(chunks[i], expected[i]));
  }
  CHECK(counterSum(bytewise.counters()) == expected.size());
  CHECK(bytewise.counters().commands_ok == host_frames);
  for (const ftp::RxCounters* k : {&bytewise.counters(), &chunked.counters()}) {
    CHECK(k->commands_ok == sum.commands_ok);
    CHECK(k->empty_frames == sum.empty_frames);
    CHECK(k->overflows == sum.overflows);
    CHECK(k->framing_errors == sum.framing_errors);
    CHECK(k->crc_errors == sum.crc_errors);
    CHECK(k->rejected == sum.rejected);
  }
}

// =============================================================================================
// Receiver behaviour of our own

TEST_CASE("receiver: resynchronises at the next delimiter after garbage") {
  const Bytes ping1 = commandWire(0x01, 1, {});
  const Bytes ping2 = commandWire(0x01, 2, {});
  const Bytes ping3 = commandWire(0x01, 3, {});

  SUBCASE("garbage ended by a delimiter costs nothing else") {
    ftp::CommandReceiver rx;
    const Fed fed = feedBytes(rx, concat({{0x13, 0x37, 0xFF, 0x00}, ping1, {0x05, 0x11, 0x00},
                                          ping2}));
    REQUIRE(fed.results.size() == 4);
    CHECK(asInt(fed.results[0].error) == asInt(ftp::RxError::Cobs));
    CHECK(asInt(fed.results[1].error) == asInt(ftp::RxError::None));
    CHECK(fed.results[1].command.request_id == 1);
    CHECK(asInt(fed.results[2].error) == asInt(ftp::RxError::Cobs));
    CHECK(asInt(fed.results[3].error) == asInt(ftp::RxError::None));
    CHECK(fed.results[3].command.request_id == 2);
    CHECK(rx.counters().framing_errors == 2);
    CHECK(rx.counters().commands_ok == 2);
  }
  SUBCASE("garbage glued to a frame loses that frame only") {
    ftp::CommandReceiver rx;
    const Fed fed = feedBytes(rx, concat({{0x42, 0x42}, ping1, ping2}));
    REQUIRE(fed.results.size() == 2);
    CHECK(asInt(fed.results[0].error) != asInt(ftp::RxError::None));
    CHECK(asInt(fed.results[0].nack) == asInt(ftp::NackError::None));  // not answered
    CHECK(asInt(fed.results[1].error) == asInt(ftp::RxError::None));
    CHECK(fed.results[1].command.request_id == 2);
  }
  SUBCASE("a frame cut short by a delimiter, then the next frame") {
    ftp::CommandReceiver rx;
    Bytes cut(ping1.begin(), ping1.end() - 3);
    cut.push_back(0x00);
    const Fed fed = feedBytes(rx, concat({cut, ping3}));
    REQUIRE(fed.results.size() == 2);
    CHECK(asInt(fed.results[0].error) != asInt(ftp::RxError::None));
    CHECK(asInt(fed.results[1].error) == asInt(ftp::RxError::None));
    CHECK(fed.results[1].command.request_id == 3);
  }
  SUBCASE("clear() drops a partial frame") {
    ftp::CommandReceiver rx;
    CHECK(feedBytes(rx, {0x42, 0x42, 0x42}).results.empty());
    rx.clear();
    const Fed fed = feedBytes(rx, ping1);
    REQUIRE(fed.results.size() == 1);
    CHECK(asInt(fed.results[0].error) == asInt(ftp::RxError::None));
  }
}

TEST_CASE("receiver: an over-long run is counted once and the next frame recovered") {
  const Bytes ping = commandWire(0x01, 77, {});
  ftp::CommandReceiver rx;
  Bytes run(1000, 0x41);
  Fed fed = feedBytes(rx, run);
  CHECK(fed.results.empty());
  CHECK(rx.counters().overflows == 0);  // judged at the delimiter
  fed = feedBytes(rx, concat({{0x00}, ping}));
  REQUIRE(fed.results.size() == 2);
  CHECK(asInt(fed.results[0].error) == asInt(ftp::RxError::TooLong));
  CHECK(asInt(fed.results[0].nack) == asInt(ftp::NackError::None));
  CHECK(asInt(fed.results[1].error) == asInt(ftp::RxError::None));
  CHECK(fed.results[1].command.request_id == 77);
  CHECK(rx.counters().overflows == 1);
  CHECK(rx.counters().commands_ok == 1);
  CHECK(counterSum(rx.counters()) == 2);
}

TEST_CASE("receiver: the length limit sits exactly at kMaxEncoded") {
  // A 128-byte frame (the maximum) encodes to 129 bytes: judged, not too_long. As a PING with
  // 123 payload bytes it is intact but of the wrong length.
  Bytes payload(ftp::kMaxFrame - ftp::kMinFrame, 0x55);
  const Bytes wire = commandWire(0x01, 9, payload);
  REQUIRE(wire.size() == ftp::kMaxEncoded + 1u);
  ftp::CommandReceiver rx;
  Fed fed = feedBytes(rx, wire);
  REQUIRE(fed.results.size() == 1);
  CHECK(asInt(fed.results[0].error) == asInt(ftp::RxError::BadPayload));
  CHECK(asInt(fed.results[0].nack) == asInt(ftp::NackError::BadLength));
  CHECK(fed.results[0].command.request_id == 9);

  // One more byte before the delimiter is too long.
  Bytes longer(wire.begin(), wire.end() - 1);
  longer.push_back(0x55);
  longer.push_back(0x00);
  fed = feedBytes(rx, longer);
  REQUIRE(fed.results.size() == 1);
  CHECK(asInt(fed.results[0].error) == asInt(ftp::RxError::TooLong));
}

TEST_CASE("receiver: argument ranges of section 5") {
  struct Case {
    uint8_t type;
    Bytes payload;
    ftp::NackError nack;  // None = accepted
  };
  const Case cases[] = {
      {0x05, {0x01, 0x00, 0x00, 0x00}, ftp::NackError::None},  // samples 0 clears
      {0x05, {0xFF, 0xFF, 0x00, 0x01}, ftp::NackError::None},  // mask 0xFFFF, 256 samples
      {0x05, {0x00, 0x00, 0x01, 0x00}, ftp::NackError::BadArgument},
      {0x05, {0x01, 0x00, 0x01, 0x01}, ftp::NackError::BadArgument},  // 257
      {0x05, {0x01, 0x00, 0xFF, 0xFF}, ftp::NackError::BadArgument},
      {0x05, {0x01, 0x00, 0x01, 0x00, 0x00}, ftp::NackError::BadLength},
      {0x06, {10, 1}, ftp::NackError::None},
      {0x06, {80, 255}, ftp::NackError::None},
      {0x06, {0, 1}, ftp::NackError::BadArgument},
      {0x06, {81, 1}, ftp::NackError::BadArgument},
      {0x06, {80}, ftp::NackError::BadLength},
      {0x07, {128}, ftp::NackError::None},
      {0x07, {32}, ftp::NackError::None},
      {0x07, {0}, ftp::NackError::BadArgument},
      {0x07, {127}, ftp::NackError::BadArgument},
      {0x07, {}, ftp::NackError::BadLength},
      {0x09, {0}, ftp::NackError::None},
      {0x09, {255}, ftp::NackError::BadArgument},
      {0x0A, {}, ftp::NackError::None},
      {0x0A, {0}, ftp::NackError::BadLength},
      {0x08, {1, 2}, ftp::NackError::BadLength},
      {0x00, {}, ftp::NackError::UnknownCommand},
      {0x0B, {}, ftp::NackError::BadLength},  // SET_TARE_OFFSETS without its mask
      {0x0C, {}, ftp::NackError::UnknownCommand},
      {0x0B, {0x01, 0x00, 0xFF, 0xFF, 0x7F}, ftp::NackError::None},
      {0x0B, {0x01, 0x00, 0xFF, 0xFF}, ftp::NackError::BadLength},
      {0x0B, {0x00, 0x00}, ftp::NackError::BadArgument},
      {0x84, {1, 0, 1}, ftp::NackError::UnknownCommand},  // an ACK sent to the device
      {0xFF, {}, ftp::NackError::UnknownCommand},
  };
  for (const Case& c : cases) {
    INFO("type " << int(c.type) << " payload " << toHex(c.payload));
    ftp::CommandReceiver rx;
    const Fed fed = feedBytes(rx, commandWire(c.type, 0xBEEF, c.payload));
    REQUIRE(fed.results.size() == 1);
    const ftp::RxResult& r = fed.results[0];
    CHECK(asInt(r.nack) == asInt(c.nack));
    CHECK(asInt(r.command.type) == c.type);
    CHECK(r.command.request_id == 0xBEEF);
    if (c.nack == ftp::NackError::None) {
      CHECK(asInt(r.error) == asInt(ftp::RxError::None));
    } else if (c.nack == ftp::NackError::UnknownCommand) {
      CHECK(asInt(r.error) == asInt(ftp::RxError::UnknownType));
    } else {
      CHECK(asInt(r.error) == asInt(ftp::RxError::BadPayload));
    }
  }
}

TEST_CASE("receiver: counters add up and reset") {
  ftp::CommandReceiver rx;
  const Bytes stream = concat({{0x00, 0x00}, commandWire(0x01, 1, {}), {0x09, 0x00},
                               commandWire(0x7E, 2, {}), Bytes(200, 0x41), {0x00}});
  const Fed fed = feedBytes(rx, stream);
  CHECK(fed.results.size() == 6);
  const ftp::RxCounters& k = rx.counters();
  CHECK(k.empty_frames == 2);
  CHECK(k.commands_ok == 1);
  CHECK(k.framing_errors == 1);
  CHECK(k.rejected == 1);
  CHECK(k.overflows == 1);
  CHECK(k.crc_errors == 0);
  CHECK(counterSum(k) == 6);
  rx.resetCounters();
  CHECK(counterSum(rx.counters()) == 0);
}

// =============================================================================================
// COBS and CRC edge cases

TEST_CASE("cobs: decoder errors") {
  uint8_t out[300];
  size_t n = 0;
  const uint8_t zero_code[] = {0x00};
  const uint8_t zero_code_later[] = {0x02, 0x11, 0x00, 0x22};
  const uint8_t past_end[] = {0x05, 0x11, 0x22};
  CHECK_FALSE(ftp::cobsDecode(zero_code, 0, out, sizeof(out), &n));  // no code byte
  CHECK_FALSE(ftp::cobsDecode(zero_code, 1, out, sizeof(out), &n));
  CHECK_FALSE(ftp::cobsDecode(zero_code_later, 4, out, sizeof(out), &n));
  CHECK_FALSE(ftp::cobsDecode(past_end, 3, out, sizeof(out), &n));
  // Capacity is respected.
  const uint8_t ok[] = {0x03, 0x11, 0x22, 0x02, 0x33};
  CHECK_FALSE(ftp::cobsDecode(ok, sizeof(ok), out, 3, &n));
  REQUIRE(ftp::cobsDecode(ok, sizeof(ok), out, 4, &n));
  CHECK(toHex(out, n) == "11220033");
  // 0xFF block followed by more: no implied zero.
  Bytes ff(1, 0xFF);
  for (int i = 0; i < 254; ++i) ff.push_back(0x41);
  ff.push_back(0x02);
  ff.push_back(0x42);
  REQUIRE(ftp::cobsDecode(ff.data(), ff.size(), out, sizeof(out), &n));
  CHECK(n == 255);
  CHECK(out[253] == 0x41);
  CHECK(out[254] == 0x42);
}

TEST_CASE("crc: known values and sensitivity") {
  CHECK(ftp::crc16(nullptr, 0) == 0xFFFF);
  const uint8_t zeros[4] = {0, 0, 0, 0};
  CHECK(ftp::crc16(zeros, 4) != 0);  // init 0xFFFF: leading zeros count
  CHECK(ftp::crc16(zeros, 3) != ftp::crc16(zeros, 4));
  CHECK(ftp::crc16Update(0xFFFF, '1') == ftp::crc16(reinterpret_cast<const uint8_t*>("1"), 1));
}

// =============================================================================================
// 24-bit helpers

TEST_CASE("int24: sign extension of raw HX711 words") {
  CHECK(ftp::signExtend24(0x000000) == 0);
  CHECK(ftp::signExtend24(0x000001) == 1);
  CHECK(ftp::signExtend24(0x7FFFFF) == 8388607);
  CHECK(ftp::signExtend24(0x800000) == -8388608);
  CHECK(ftp::signExtend24(0xFFFFFF) == -1);
  CHECK(ftp::signExtend24(0xFFFFFE) == -2);
  CHECK(ftp::signExtend24(0xFF123456) == 0x123456);  // bits above 23 ignored
}

TEST_CASE("int24: saturation of raw words") {
  CHECK(ftp::isSaturatedRaw(0x7FFFFF));
  CHECK(ftp::isSaturatedRaw(0x800000));
  CHECK_FALSE(ftp::isSaturatedRaw(0x7FFFFE));
  CHECK_FALSE(ftp::isSaturatedRaw(0x800001));
  CHECK_FALSE(ftp::isSaturatedRaw(0xFFFFFF));
  CHECK_FALSE(ftp::isSaturatedRaw(0));
}

TEST_CASE("int24: clipping sets the flag only when it clips") {
  bool sat = false;
  CHECK(ftp::clipInt24(0, sat) == 0);
  CHECK(ftp::clipInt24(8388607, sat) == 8388607);
  CHECK(ftp::clipInt24(-8388608, sat) == -8388608);
  CHECK_FALSE(sat);
  CHECK(ftp::clipInt24(8388608, sat) == 8388607);
  CHECK(sat);
  sat = false;
  CHECK(ftp::clipInt24(-8388609, sat) == -8388608);
  CHECK(sat);
  sat = false;
  CHECK(ftp::clipInt24(INT32_MAX, sat) == 8388607);
  CHECK(sat);
  sat = false;
  CHECK(ftp::clipInt24(INT32_MIN, sat) == -8388608);
  CHECK(sat);
  // The flag is sticky: a later in-range value does not clear it.
  CHECK(ftp::clipInt24(5, sat) == 5);
  CHECK(sat);
}

TEST_CASE("int24: sample value = raw - offset, clipped, with saturation") {
  bool sat = false;
  CHECK(ftp::sampleValue(0x000064, 0, sat) == 100);
  CHECK(ftp::sampleValue(0x000064, 150, sat) == -50);
  CHECK(ftp::sampleValue(0xFFFFFF, -1, sat) == 0);
  CHECK_FALSE(sat);
  CHECK(ftp::sampleValue(0x7FFFFF, 0, sat) == 8388607);  // chip at its limit
  CHECK(sat);
  sat = false;
  CHECK(ftp::sampleValue(0x800000, 1000, sat) == -8388608);  // chip limit, then clipped
  CHECK(sat);
  sat = false;
  CHECK(ftp::sampleValue(0x700000, -0x200000, sat) == 8388607);  // clipped by the tare
  CHECK(sat);
  sat = false;
  CHECK(ftp::sampleValue(0x900000, 0x200000, sat) == -8388608);
  CHECK(sat);
}

// =============================================================================================
// Encoder

namespace {

ftp::Sample sample4() {
  ftp::Sample s{};
  s.timestamp_us = 1000;
  s.channels = 4;
  s.values[0] = 1;
  return s;
}

// Checks that wire bytes are one intact frame and returns it decoded.
Bytes checkedFrame(const uint8_t* wire, size_t n) {
  Bytes w(wire, wire + n);
  for (size_t i = 0; i + 1 < n; ++i) {
    REQUIRE(w[i] != 0x00);
  }
  const Bytes f = decodeWire(w);
  REQUIRE(f.size() >= ftp::kMinFrame);
  REQUIRE(ftp::crc16(f.data(), f.size() - 2) == (f[f.size() - 2] | (f[f.size() - 1] << 8)));
  return f;
}

}  // namespace

TEST_CASE("encoder: seq is shared by all types and wraps 65535 -> 0") {
  ftp::Encoder enc;
  CHECK(enc.seq() == 0);
  uint8_t buf[ftp::kMaxWire];
  enc.setSeq(65534);
  size_t n = enc.encodeSample(sample4(), buf, sizeof(buf));
  REQUIRE(n > 0);
  Bytes f = checkedFrame(buf, n);
  CHECK((f[1] | (f[2] << 8)) == 65534);
  n = enc.encodeAck(5, ftp::MsgType::Ping, buf, sizeof(buf));
  f = checkedFrame(buf, n);
  CHECK(f[0] == 0x84);
  CHECK((f[1] | (f[2] << 8)) == 65535);
  CHECK(enc.seq() == 0);
  const char text[] = "x";
  n = enc.encodeLog(ftp::LogLevel::Info, text, 1, buf, sizeof(buf));
  f = checkedFrame(buf, n);
  CHECK((f[1] | (f[2] << 8)) == 0);
  CHECK(enc.seq() == 1);
}

TEST_CASE("encoder: rejects bad arguments without consuming a seq") {
  ftp::Encoder enc;
  enc.setSeq(100);
  uint8_t buf[ftp::kMaxWire];

  ftp::Sample s = sample4();
  s.channels = 0;
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 0);
  s.channels = 17;
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 0);
  s.channels = 16;
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 64);  // 62-byte frame, 64 on the wire (sec. 7)
  enc.setSeq(100);
  s = sample4();
  s.timeout_mask = 0x0010;  // channel 4 of a 4-channel frame
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 0);
  s = sample4();
  s.saturation_mask = 0x8000;
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 0);
  s = sample4();
  s.values[3] = 8388608;
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 0);
  s.values[3] = -8388609;
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 0);
  s = sample4();
  s.values[4] = 0x7FFFFFFF;  // beyond channels: ignored
  CHECK(enc.encodeSample(s, buf, sizeof(buf)) == 28);  // 26-byte frame, 28 on the wire
  enc.setSeq(100);

  ftp::Info info{};
  info.channels = 0;
  CHECK(enc.encodeInfo(info, buf, sizeof(buf)) == 0);
  info.channels = 17;
  CHECK(enc.encodeInfo(info, buf, sizeof(buf)) == 0);
  info.channels = 4;
  info.tare_offsets[2] = -8388609;
  CHECK(enc.encodeInfo(info, buf, sizeof(buf)) == 0);

  char text[102];
  memset(text, 'y', sizeof(text));
  CHECK(enc.encodeLog(ftp::LogLevel::Info, text, 101, buf, sizeof(buf)) == 0);
  CHECK(enc.encodeLog(static_cast<ftp::LogLevel>(4), text, 1, buf, sizeof(buf)) == 0);
  CHECK(enc.encodeLog(ftp::LogLevel::Info, nullptr, 1, buf, sizeof(buf)) == 0);
  CHECK(enc.encodeNack(1, ftp::MsgType::Ping, ftp::NackError::None, buf, sizeof(buf)) == 0);
  CHECK(enc.seq() == 100);

  // 100 bytes is the longest line: the largest v1 frame (106 bytes).
  const size_t n = enc.encodeLog(ftp::LogLevel::Info, text, 100, buf, sizeof(buf));
  CHECK(n == 108);
  CHECK(checkedFrame(buf, n).size() == 106);
  CHECK(enc.seq() == 101);

  Bytes f = checkedFrame(buf, enc.encodeLog(ftp::LogLevel::Debug, nullptr, 0, buf, sizeof(buf)));
  CHECK(f.size() == 6);
}

TEST_CASE("encoder: capacity is checked exactly") {
  ftp::Encoder enc;
  uint8_t buf[ftp::kMaxWire];
  ftp::Stats st{};
  st.frames_sent = 1;
  // STATS: 45-byte frame, 47 on the wire (section 7).
  CHECK(enc.encodeStats(st, buf, 46) == 0);
  CHECK(enc.encodeStats(st, nullptr, 47) == 0);
  CHECK(enc.seq() == 0);
  CHECK(enc.encodeStats(st, buf, 47) == 47);
  CHECK(buf[46] == 0x00);
  CHECK(enc.encodeAck(1, ftp::MsgType::Ping, buf, 9) == 0);
  CHECK(enc.encodeAck(1, ftp::MsgType::Ping, buf, 10) == 10);
}

TEST_CASE("encoder -> receiver: an encoded NACK is judged as a device message at the device") {
  // The receiver must not accept the device's own messages as commands (loopback wiring).
  ftp::Encoder enc;
  uint8_t buf[ftp::kMaxWire];
  const size_t n = enc.encodeNack(3, ftp::MsgType::Tare, ftp::NackError::Busy, buf, sizeof(buf));
  ftp::CommandReceiver rx;
  const Fed fed = feedBytes(rx, Bytes(buf, buf + n));
  REQUIRE(fed.results.size() == 1);
  CHECK(asInt(fed.results[0].error) == asInt(ftp::RxError::UnknownType));
  CHECK(asInt(fed.results[0].command.type) == 0x85);
}
