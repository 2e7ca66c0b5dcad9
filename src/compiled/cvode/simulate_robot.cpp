// The compiled library: the definitions of <sid/cvode/simulate_robot.hpp>, compiled once.
#include <sid/cvode/simulate_robot-inl.hpp>
