// The compiled library: the definitions of <sid/cvode/identify_robot.hpp>, compiled once.
#include <sid/cvode/identify_robot-inl.hpp>
