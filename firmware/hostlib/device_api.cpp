// The C API of fingertip_device.h: lib/fingertip_core's Device on a SimBoard, run from event
// to event (a conversion, a chip deadline, a STATS) instead of polling in a loop.
#include <string.h>

#include <new>

#include "fingertip_device.h"
#include "sim_board.h"

struct FtdDevice {
  FtdDevice(uint8_t n, uint32_t build_id, uint8_t reset_cause)
      : config{n, build_id, reset_cause}, board(n), dev(board, ch, config) {}

  const ftc::DeviceConfig config;
  fth::SimBoard board;
  ftc::ChannelState ch[ftp::kMaxChannels];
  ftc::Device dev;
};

namespace {

// Signed wrap-around distance from device time `from` (u32, micros()) to `to`.
inline int32_t ahead(uint32_t to, uint32_t from) { return static_cast<int32_t>(to - from); }

// The 64-bit time at which micros() first reaches the u32 device time t (now if it has).
uint64_t whenReached(const fth::SimBoard& b, uint32_t t) {
  const uint64_t now = b.now();
  const int32_t d = ahead(t, fth::SimBoard::micros(now));
  if (d <= 0) return now;
  return now - now % 4u + ((static_cast<uint64_t>(d) + 3u) & ~static_cast<uint64_t>(3u));
}

int64_t nextDue(const FtdDevice& d) {
  int64_t due = -1;
  const auto consider = [&due](uint64_t t) {
    if (due < 0 || static_cast<int64_t>(t) < due) due = static_cast<int64_t>(t);
  };
  if (d.dev.powered() && d.board.powered()) {
    consider(d.board.nextConversion());
    consider(whenReached(d.board, d.dev.deadlineUs()));
  }
  if (d.dev.streaming()) consider(whenReached(d.board, d.dev.nextStatsUs()));
  return due;
}

// One main-loop iteration at the current time; the time since the previous one was idle.
int pollOnce(FtdDevice* d) {
  d->dev.forgetLoopStart();
  d->dev.poll();
  const int e = d->board.takeError();
  return e == fth::kBoardInputsFailed ? FTD_E_INPUTS : e == fth::kBoardBadInput ? FTD_E_NAN : 0;
}

// What a running call returns: the bytes waiting for the host, or the error.
int64_t outcome(const FtdDevice* d, int error) {
  return error != FTD_OK ? error : static_cast<int64_t>(d->board.tx().size());
}

// Placement-new of the whole device: exactly a power-on reset, with nothing left over.
void rebuild(FtdDevice* d) {
  const ftc::DeviceConfig config = d->config;
  const uint16_t dead = ftd_dead_mask(d);
  void* ctx = nullptr;
  fth::InputsFn fn = d->board.inputs(&ctx);
  d->~FtdDevice();
  new (d) FtdDevice(config.channels, config.build_id, config.reset_cause);
  d->board.setInputs(fn, ctx);
  ftd_set_dead_mask(d, dead);
}

const char* const kStatsFields[] = {
#define FTD_NAME(name) #name,
    FTP_STATS_FIELDS(FTD_NAME)
#undef FTD_NAME
        nullptr};

struct Constant {
  const char* name;
  int64_t value;
};

#define FTD_MSG(name, type) {name, static_cast<int64_t>(ftp::MsgType::type)}
#define FTD_NACK(name, err) {name, static_cast<int64_t>(ftp::NackError::err)}
const Constant kConstants[] = {
    {"protocol_major", ftp::kProtocolMajor},
    {"protocol_minor", ftp::kProtocolMinor},
    {"header_size", ftp::kHeaderSize},
    {"crc_size", ftp::kCrcSize},
    {"min_frame", ftp::kMinFrame},
    {"max_frame", ftp::kMaxFrame},
    {"max_encoded", ftp::kMaxEncoded},
    {"max_channels", ftp::kMaxChannels},
    {"max_log_text", ftp::kMaxLogText},
    {"max_tare_samples", ftp::kMaxTareSamples},
    {"int24_min", ftp::kInt24Min},
    {"int24_max", ftp::kInt24Max},
    {"sample_payload_fixed", ftp::kSamplePayloadFixed},
    {"info_payload_fixed", ftp::kInfoPayloadFixed},
    {"stats_payload", ftp::kStatsPayload},
    {"ack_payload", ftp::kAckPayload},
    {"nack_payload", ftp::kNackPayload},
    {"flag_streaming", ftp::kFlagStreaming},
    {"flag_powered_down", ftp::kFlagPoweredDown},
    {"flag_tare_in_progress", ftp::kFlagTareInProgress},
    {"info_reason_request", ftp::kInfoReasonRequest},
    {"info_reason_boot", ftp::kInfoReasonBoot},
    {"firmware_major", ftc::kFwMajor},
    {"firmware_minor", ftc::kFwMinor},
    {"firmware_patch", ftc::kFwPatch},
    {"settle_periods", ftc::kSettlePeriods},
    {"stats_interval_us", ftc::kStatsIntervalUs},
    FTD_MSG("ping", Ping),
    FTD_MSG("get_info", GetInfo),
    FTD_MSG("start", Start),
    FTD_MSG("stop", Stop),
    FTD_MSG("tare", Tare),
    FTD_MSG("set_rate", SetRate),
    FTD_MSG("set_gain", SetGain),
    FTD_MSG("reset_counters", ResetCounters),
    FTD_MSG("set_power", SetPower),
    FTD_MSG("get_stats", GetStats),
    FTD_MSG("set_tare_offsets", SetTareOffsets),
    FTD_MSG("sample", Sample),
    FTD_MSG("info", Info),
    FTD_MSG("stats", Stats),
    FTD_MSG("ack", Ack),
    FTD_MSG("nack", Nack),
    FTD_MSG("log", Log),
    FTD_NACK("unknown_command", UnknownCommand),
    FTD_NACK("bad_length", BadLength),
    FTD_NACK("bad_argument", BadArgument),
    FTD_NACK("busy", Busy),
    FTD_NACK("chip_timeout", ChipTimeout),
    FTD_NACK("powered_down", PoweredDown),
};
#undef FTD_MSG
#undef FTD_NACK
const int kConstantCount = static_cast<int>(sizeof(kConstants) / sizeof(kConstants[0]));

// A due event that does not move after being served would loop forever: give up instead.
const int kMaxPollsAtOneTime = 64;

}  // namespace

extern "C" {

FtdDevice* ftd_create(uint8_t channels, uint32_t build_id, uint8_t reset_cause) {
  if (channels < 1 || channels > ftp::kMaxChannels) return nullptr;
  return new (std::nothrow) FtdDevice(channels, build_id, reset_cause);
}

void ftd_destroy(FtdDevice* d) { delete d; }

void ftd_reset(FtdDevice* d) { rebuild(d); }

void ftd_set_inputs(FtdDevice* d, ftd_inputs_fn fn, void* ctx) { d->board.setInputs(fn, ctx); }

int ftd_set_dead_mask(FtdDevice* d, uint16_t mask) {
  if (!ftp::maskFitsChannels(mask, d->config.channels)) return FTD_E_ARGUMENT;
  for (uint8_t i = 0; i < d->config.channels; ++i) {
    d->board.setMode(i, ((mask >> i) & 1u) ? fth::ChipMode::Absent : fth::ChipMode::Ok);
  }
  return FTD_OK;
}

uint16_t ftd_dead_mask(const FtdDevice* d) {
  uint16_t m = 0;
  for (uint8_t i = 0; i < d->config.channels; ++i) {
    if (d->board.mode(i) == fth::ChipMode::Absent) m = static_cast<uint16_t>(m | (1u << i));
  }
  return m;
}

int64_t ftd_boot(FtdDevice* d, uint64_t start_us) {
  rebuild(d);
  d->board.setNow(start_us);
  d->dev.boot();
  return outcome(d, FTD_OK);
}

int64_t ftd_receive(FtdDevice* d, const uint8_t* data, size_t len) {
  d->board.pushRx(data, len);
  // One command per main-loop iteration, as on the Uno; a partial frame stays in the receiver.
  while (d->board.rxPending()) {
    const int e = pollOnce(d);
    if (e != 0) return e;
  }
  return outcome(d, FTD_OK);
}

int64_t ftd_advance(FtdDevice* d, uint64_t to_us) {
  int polls_here = 0;
  uint64_t last = d->board.now();
  for (;;) {
    const int64_t due = nextDue(*d);
    if (due < 0 || static_cast<uint64_t>(due) > to_us) break;
    d->board.setNow(static_cast<uint64_t>(due));
    polls_here = d->board.now() == last ? polls_here + 1 : 0;
    last = d->board.now();
    if (polls_here > kMaxPollsAtOneTime) return FTD_E_STUCK;
    const int e = pollOnce(d);
    if (e != 0) return e;
  }
  d->board.setNow(to_us);
  return outcome(d, FTD_OK);
}

int64_t ftd_next_due(const FtdDevice* d) { return nextDue(*d); }

uint64_t ftd_now(const FtdDevice* d) { return d->board.now(); }

const uint8_t* ftd_tx_data(const FtdDevice* d) { return d->board.tx().data(); }
size_t ftd_tx_size(const FtdDevice* d) { return d->board.tx().size(); }
void ftd_tx_clear(FtdDevice* d) { d->board.clearTx(); }

void ftd_state(FtdDevice* d, FtdState* out) {
  memset(out, 0, sizeof(*out));
  const ftc::Device& v = d->dev;
  out->channels = v.channels();
  out->rate_sps = v.rateSps();
  out->decimation = v.decimation();
  out->gain = v.gain();
  out->flags = v.flags();
  out->streaming = v.streaming();
  out->powered = v.powered();
  out->tare_active = v.tareActive();
  out->live_mask = v.liveMask();
  out->stale_mask = v.staleMask();
  for (uint8_t i = 0; i < v.channels(); ++i) out->offsets[i] = v.offset(i);
  const ftp::Stats s = v.stats(d->board.nowUs());
  static_assert(sizeof(s) == sizeof(out->stats), "STATS is ten u32");
  memcpy(out->stats, &s, sizeof(s));
}

int ftd_constant(const char* name, int64_t* value) {
  for (const Constant& c : kConstants) {
    if (strcmp(c.name, name) == 0) {
      *value = c.value;
      return 0;
    }
  }
  return -1;
}

const char* ftd_constant_name(int i) {
  return i >= 0 && i < kConstantCount ? kConstants[i].name : nullptr;
}

const char* ftd_stats_field(int i) {
  const int n = static_cast<int>(sizeof(kStatsFields) / sizeof(kStatsFields[0])) - 1;
  return i >= 0 && i < n ? kStatsFields[i] : nullptr;
}

}  // extern "C"
