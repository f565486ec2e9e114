#pragma once
// Typed access to the free-form attributes of a particle file (ParticleData::attributes): a malformed
// value is an InputError naming the file and the attribute, never a bare "stod".
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Parse `text` as a finite double, the whole string (no trailing characters). nullopt otherwise.
std::optional<double> parseFiniteDouble(std::string_view text);

/// The attribute `key` of `data` as a finite number, or nullopt if absent. Throws InputError
/// "FILE: attribute KEY: 'VALUE' is not a finite number" if present and malformed.
std::optional<double> numericAttribute(const ParticleData& data, const std::string& key,
                                       const std::filesystem::path& file);

/// Like numericAttribute() but the attribute must exist: InputError "FILE: attribute KEY is missing".
double requireNumericAttribute(const ParticleData& data, const std::string& key, const std::filesystem::path& file);

}  // namespace polydem::io
