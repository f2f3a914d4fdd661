"""Force: the calibration from counts to newtons (:mod:`.calibrate` runs the parts in
:mod:`.calibration`), its recording session and alignment with a reference (:mod:`.calib_record`,
:mod:`.calib_session`, :mod:`.align`), calibration with weights (:mod:`.weights`) and the
runtime force model (:mod:`.runtime`, loaded for a device by :mod:`.force_load`)."""
