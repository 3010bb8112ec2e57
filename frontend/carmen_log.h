// Reading CARMEN laser logs (plain or gzip'd): laser scans, raw odometry and
// the reference poses that corrected logs carry.
#pragma once
