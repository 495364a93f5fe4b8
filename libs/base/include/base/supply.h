#pragma once
// The servo supply voltage a robot runs on when its description does not say (a bus without
// Bus.supply_voltage_v): the FUmanoid's battery, a 4S LiPo of 14.8 V nominal (4 x 3.7 V). The
// gateway's bus configuration, the physics world and the devices' feedback all start from it.

namespace doppel {

inline constexpr double kDefaultSupplyVoltage_v = 14.8;  // V, 4S LiPo nominal

}  // namespace doppel
