// The compiled library: the definitions of <sid/cvode/diagnose_robot.hpp>, compiled once.
#include <sid/cvode/diagnose_robot-inl.hpp>
