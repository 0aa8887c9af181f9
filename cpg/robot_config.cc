#include "cpg/robot_config.h"
