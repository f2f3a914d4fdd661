"""Reference force sensors for calibration: what ``fingertip calibrate record`` joins the
fingertip with.

- :mod:`.rdt`: an ATI Net F/T or Axia over its UDP streaming protocol (RDT);
- :mod:`.csvref`: a timestamped CSV from any other sensor;
- :mod:`.samples`: :class:`ReferenceSamples` (host-clock times and forces) and the
  :class:`WrenchSource` interface every live input implements. A ROS 2
  ``geometry_msgs/WrenchStamped`` subscriber (the middleware of issue 16) plugs in there: it
  needs ``start()``, ``stop() -> ReferenceSamples`` and ``counters``.
"""
from .csvref import ReferenceFormatError, load_reference_csv
from .rdt import RdtClient, RdtRecord, decode_record, encode_request
from .samples import ReferenceError, ReferenceSamples, WrenchSource

__all__ = ["RdtClient", "RdtRecord", "ReferenceError", "ReferenceFormatError",
           "ReferenceSamples", "WrenchSource", "decode_record", "encode_request",
           "load_reference_csv"]
