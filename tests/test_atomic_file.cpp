#include <vox/formats/atomic_file.h>
#include <vox/formats/error.h>

#include "test_support.h"

using vox::AtomicFile;
using vox::test::ScratchDir;

TEST(AtomicFile, CommitRenamesIntoPlaceAndLeavesNoTemporary) {
    ScratchDir dir;
    {
        AtomicFile file(dir / "out.bin");
        EXPECT_TRUE(std::filesystem::exists(file.temporaryPath()));
        EXPECT_FALSE(std::filesystem::exists(dir / "out.bin"));
        file.write("hello ");
        file.write("world");
        file.commit();
    }
    EXPECT_EQ(vox::test::readText(dir / "out.bin"), "hello world");
    EXPECT_EQ(dir.files(), std::vector<std::string>{"out.bin"});
}

TEST(AtomicFile, UncommittedFileLeavesThePreviousOutputUntouched) {
    ScratchDir dir;
    vox::test::writeText(dir / "out.bin", "previous");
    {
        AtomicFile file(dir / "out.bin");
        file.write("partial new contents");
    }  // destroyed without commit, as when an exception unwinds
    EXPECT_EQ(vox::test::readText(dir / "out.bin"), "previous");
    EXPECT_EQ(dir.files(), std::vector<std::string>{"out.bin"});
}

TEST(AtomicFile, CommitReplacesAnExistingFile) {
    ScratchDir dir;
    vox::test::writeText(dir / "out.bin", "previous");
    vox::writeFileAtomically(dir / "out.bin", "new");
    EXPECT_EQ(vox::test::readText(dir / "out.bin"), "new");
}

TEST(AtomicFile, WritesLargerThanItsBufferArriveWhole) {
    ScratchDir dir;
    std::string big(300000, '\0');
    for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 7 + i / 256);
    {
        AtomicFile file(dir / "big.bin");
        for (std::size_t at = 0; at < big.size(); at += 1000) file.write(big.data() + at, std::min<std::size_t>(1000, big.size() - at));
        file.commit();
    }
    EXPECT_EQ(vox::test::readText(dir / "big.bin"), big);
}

TEST(AtomicFile, MissingDirectoryIsAnIoError) {
    ScratchDir dir;
    try {
        AtomicFile file(dir / "no" / "such" / "dir" / "out.bin");
        FAIL() << "expected IoError";
    } catch (const vox::IoError& e) {
        EXPECT_EQ(e.exitCode(), vox::ExitCode::Io);
        EXPECT_NE(std::string(e.what()).find("out.bin"), std::string::npos) << e.what();
    }
}

TEST(AtomicFile, TemporaryNamesAreRecognisable) {
    ScratchDir dir;
    AtomicFile file(dir / "scene.esvo");
    EXPECT_TRUE(AtomicFile::isTemporaryName(file.temporaryPath().filename().string())) << file.temporaryPath();
    EXPECT_FALSE(AtomicFile::isTemporaryName("scene.esvo"));
    EXPECT_FALSE(AtomicFile::isTemporaryName(".tmp-"));
    EXPECT_FALSE(AtomicFile::isTemporaryName("scene.tmp-abcdef"));  // no leading dot
}
