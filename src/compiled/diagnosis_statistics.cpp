// The compiled library: the definitions of the diagnosis statistics in <sid/diagnosis/>.
#include <sid/diagnosis/hac-inl.hpp>
#include <sid/diagnosis/kinematic_floor-inl.hpp>
#include <sid/diagnosis/noise_floor-inl.hpp>
