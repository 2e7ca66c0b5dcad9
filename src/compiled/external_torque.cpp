// The compiled library: the definitions of <sid/external_torque.hpp>, compiled once.
#include <sid/external_torque-inl.hpp>
