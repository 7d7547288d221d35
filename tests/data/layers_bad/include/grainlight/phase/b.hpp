#pragma once
#include "grainlight/core/a.hpp"
