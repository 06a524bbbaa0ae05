/* Hydrobake: water-and-weather effect kernels. The one header to include. */
#ifndef HYDROBAKE_H
#define HYDROBAKE_H
#include "hbk_base.h"
#include "hbk_rng.h"
#include "hbk_image.h"
#include "hbk_exr.h"
#include "hbk_snow.h"
#include "hbk_water.h"
#include "hbk_caustics.h"
#include "hbk_rain.h"
#include "hbk_fluid.h"
#endif
