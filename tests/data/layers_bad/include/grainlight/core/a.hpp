#pragma once
#include "grainlight/phase/b.hpp"
