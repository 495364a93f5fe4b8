#pragma once
// What one simulation host offers to a transport: the simulation always, each other facet when it
// has it (null: the transport says there is none, e.g. /api/game answers 404 in a replay). A live
// doppel offers the game, team communication, world model and faults as its options started them;
// doppel-replay offers the replay.

#include "contract/faults.h"
#include "contract/game.h"
#include "contract/replay.h"
#include "contract/simulation.h"
#include "contract/teamcomm.h"
#include "contract/world_model.h"

namespace doppel::contract {

struct Facets {
  Simulation* simulation = nullptr;  // never null when served
  Replay* replay = nullptr;
  Game* game = nullptr;
  Teamcomm* teamcomm = nullptr;
  WorldModel* world_model = nullptr;
  Faults* faults = nullptr;
};

}  // namespace doppel::contract
