// What the libFuzzer harnesses share (docs/fuzzing.md): the input as a file on a tmpfs, since
// libvox's readers and importers take paths, and checksum repair, so that mutated .esvo and
// .rvol files get past their checksums into the structure the validators check.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace vox::fuzz {

/// A file in a private directory (under /dev/shm where it exists, else $TMPDIR or /tmp) that each
/// input is written to before a reader opens it by name. One per process and extension; the
/// directory is removed at exit.
class InputFile {
public:
    /// @p extension with its dot (".esvo", ".glb", ...): importers pick the format by it.
    explicit InputFile(const std::string& extension);
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    /// Replaces the file's contents with @p size bytes at @p data; returns its path.
    const std::filesystem::path& write(const std::uint8_t* data, std::size_t size);
    const std::filesystem::path& write(const std::vector<std::uint8_t>& bytes) {
        return write(bytes.data(), bytes.size());
    }
    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

private:
    std::filesystem::path path_;
};

/// Runs @p readAndValidate on the input as it is (written to @p input) and, where
/// @p repairChecksums changes it, once more on the repaired copy: the checksums must catch the
/// damage, and past them the structure must be checked.
template <typename Repair, typename Body>
void asIsAndWithChecksumsRepaired(InputFile& input, const std::uint8_t* data, std::size_t size,
                                  Repair repairChecksums, Body readAndValidate) {
    readAndValidate(input.write(data, size));
    std::vector<std::uint8_t> repaired(data, data + size);
    if (repairChecksums(repaired)) readAndValidate(input.write(repaired));
}

/// Rewrites every checksum of an .esvo file in @p bytes (each slice's in its directory entry, the
/// directory's and the header's) to match the bytes they cover, where the header and directory
/// say where those are inside @p bytes; leaves everything else as it is. Returns whether anything
/// changed.
bool repairEsvoChecksums(std::vector<std::uint8_t>& bytes);

/// The same for an .rvol file: each brick's in the brick directory, the directory's, the level
/// table's, both attribute layers' and the header's.
bool repairRvolChecksums(std::vector<std::uint8_t>& bytes);

}  // namespace vox::fuzz
