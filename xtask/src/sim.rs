//! `cargo xtask sim`: the virtual board (a software ET1100 + AD5663 + AD7689) driven by a
//! real EtherCAT master, with the firmware's slave application compiled for the host
//! (default) or, with `--image`, the release image on the co-simulated LPC1754 or STM32F103
//! (`tests/cosim`, run as its own binary: it links the GPL-2.0 unicorn engine, which stays
//! out of xtask). The options are [`virtual_board::tools::sim::cli::SimArgs`].

use crate::build;
use crate::util::{cargo, exec, Result};
use virtual_board::tools::sim::cli::{self, SimArgs};
use virtual_board::tools::sim::{self, Target};

#[derive(clap::Args, Debug)]
#[command(after_long_help = cli::AFTER_HELP)]
pub struct Args {
    #[command(flatten)]
    pub sim: SimArgs,
    /// Run the release image (built first) on the co-simulator of its board's MCU (LPC1754
    /// or STM32F103) instead of the host-compiled application; prints the image facts (instructions, cycles, CPU load,
    /// stack, interrupts) too.
    #[arg(long)]
    pub image: bool,
}

pub fn run(args: &Args) -> Result {
    let product = args.sim.product()?;
    if args.image {
        return run_image(product);
    }
    if args.sim.oversampling.is_some() {
        return Err(
            "--oversampling needs --image: the host-compiled application has no ADC sample \
             ring or LDAC timer, which the block PDOs are made of (docs/book/oversampling-loopback.md)"
                .into(),
        );
    }
    if product.board.mcu() != firmware::platform::board::Mcu::Lpc1754 {
        return Err(format!(
            "{}: the host-compiled application runs the LPC1754 board (the ET1100 on SPI) \
             only; `--image` runs the image for \"{}\" on the co-simulated STM32F103 \
             (docs/book/stm32-cosim.md)",
            product.name, product.board.name
        ));
    }
    cli::run(
        &args.sim,
        |echo| {
            if echo {
                return Ok(Some(Target::echo()));
            }
            match sim::firmware_target_of(product, args.sim.node_id) {
                Ok(t) => Ok(Some(t)),
                Err(why) => {
                    println!("{why}");
                    println!(
                        "(`cargo xtask sim --echo` runs the transport test responder instead)"
                    );
                    Ok(None)
                }
            }
        },
        &mut || {},
    )
}

/// The options after `sim` as given, without `--image`: the co-simulator takes the same.
fn forwarded_args() -> Vec<String> {
    std::env::args()
        .skip_while(|a| a != "sim")
        .skip(1)
        .filter(|a| a != "--image")
        .collect()
}

/// Builds `product`'s image, then runs the co-simulator's binary with it.
fn run_image(product: &'static firmware::products::Product) -> Result {
    let out = build::build(&build::Args::of(product))?;
    crate::setup::cosim()?;
    exec(
        cargo()
            .args(["run", "--quiet", "-p", "lpc1754-cosim", "--", "sim"])
            .args(forwarded_args())
            .env("LPC1754_IMAGE", &out.elf),
    )
}
