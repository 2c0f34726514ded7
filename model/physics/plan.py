"""Planning physics of a digital-TDI push-broom camera: one namespace over four job modules.

``tdicam plan`` and the run report use these closed-form models. Each job lives in its own
module and is re-exported here, so ``from tdicam.model.physics import plan; plan.ground_speed(...)``
reaches all of them:

* :mod:`tdicam.model.physics.orbit` — ground-track speed, line period, required frame rate,
  rolling-shutter window timing (Qu et al. 2010, Tao et al. 2012);
* :mod:`tdicam.model.physics.memory` — line buffers of the basic and optimized TDI structures,
  on-chip budgets, DDR bandwidth of spilled partial sums (Qu et al. 2010, Ning et al. 2019);
* :mod:`tdicam.model.physics.snr` — SNR gain of digital and charge-domain TDI (Tao et al. 2012, Zhou et al. 2008)
  and the planning model of shared quantization noise;
* :mod:`tdicam.model.physics.mtf` — the camera's along-track MTF (exposure, smear at the actual image
  speed, rolling-shutter skew, M-stage misregistration) shared with the scene simulator, and
  the paper's product (Yuan et al. 2013).

Papers: Qu Hongsong, Zhang Ye, Jin Guang, "Improving the function of area-array CMOS image
sensors with a digital-domain TDI algorithm", Optics and Precision Engineering 18(8), 2010;
Yuan Gaobin, Li Binqiao, Xu Jiangtao, Nie Kaiming, "MTF velocity-mismatch model of TDI
area-array CMOS image sensors", 2013; Ning Yonghui, Liu Hui, Zhao Qinglei, Guo Hanzhou,
"Design of a large-array high-frame-rate CMOS imaging electronics system", Optics and
Precision Engineering 27(5), 2019; Tao Shuping, Jin Guang, Qu Hongsong, He Xiaojun, Yang
Xiubin, "Design and analysis of a digital-domain TDI CMOS camera for high-resolution space
imaging", 2012; Zhou Huaide, Liu Haiying, Xu Dong, Li Guangze, Wang Ye, Liu Jinguo, "TDI
operation of interline-transfer area CCDs", Optics and Precision Engineering 16(9), 2008.

Units are SI unless a name says otherwise; spatial frequencies are in cycles per pixel
(Nyquist :data:`NYQUIST` = 0.5). Bad input raises :class:`~tdicam.errors.TdicamError` with
``NAME = V is out of range; valid: lo..hi``.
"""

from __future__ import annotations

from tdicam.model.physics import memory as _memory, mtf as _mtf, orbit as _orbit, snr as _snr
from tdicam.model.physics.memory import *  # noqa: F401,F403
from tdicam.model.physics.mtf import *  # noqa: F401,F403
from tdicam.model.physics.orbit import *  # noqa: F401,F403
from tdicam.model.physics.snr import *  # noqa: F401,F403

__all__ = [*_orbit.__all__, *_memory.__all__, *_snr.__all__, *_mtf.__all__]
