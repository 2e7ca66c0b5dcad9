// The compiled library: the definitions of <sid/cvode/identify_robot_currents.hpp>, compiled
// once.
#include <sid/cvode/identify_robot_currents-inl.hpp>
