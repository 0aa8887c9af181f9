// Umbrella header of the SNP codec (yamor::snp): frames, typed messages and
// the streaming decoder, recordings, scene snapshots. Wire format: docs/snp.md.
#pragma once

#include "proto/snp/decoder.h"
#include "proto/snp/frame.h"
#include "proto/snp/message_type.h"
#include "proto/snp/messages.h"
#include "proto/snp/recording.h"
#include "proto/snp/scene.h"
