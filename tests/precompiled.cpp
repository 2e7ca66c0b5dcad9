// The host of the sanitized pass's precompiled header (see CMakeLists.txt): it compiles the
// header and nothing else.
