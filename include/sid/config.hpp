#pragma once
/// @file
/// @brief The build mode: header-only (the default) or the compiled library.
///
/// Header-only: every header defines its functions, so including it is all a program needs. A
/// file that includes the identification or diagnosis headers then compiles their whole
/// pipelines, which costs tens of seconds of front end per file.
///
/// Compiled (SID_COMPILED_LIB, which linking the CMake target sid::compiled or
/// sid::cvode_compiled defines): the headers only declare the pipelines' non-template functions
/// and the library holds them, compiled once. Templates (the smoother, the regressor, the models
/// over a Scalar type) stay in the headers in both modes; the one exception is the least-squares
/// solver for double, which every fit calls: the library holds its instantiation and the headers
/// declare it `extern template`.
///
/// Each header X.hpp with such functions has their definitions in X-inl.hpp, marked SID_INLINE:
/// `inline` in header-only mode, nothing in the compiled library, whose sources include the
/// -inl files. The pattern is spdlog's.

#ifdef SID_COMPILED_LIB
#define SID_INLINE
#else
#define SID_HEADER_ONLY
#define SID_INLINE inline
#endif
