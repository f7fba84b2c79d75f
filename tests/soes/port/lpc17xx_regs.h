/*
 * LPC1754 registers the port uses (UM10360; addresses as in the project's
 * docs/hardware-facts.md section 7). Written for this port: only what it touches.
 */
#ifndef LPC17XX_REGS_H
#define LPC17XX_REGS_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(addr))

/* System control (UM10360 chapter 3/4). */
#define SC_BASE        0x400FC000u
#define SC_FLASHCFG    REG32(SC_BASE + 0x000)
#define SC_PLL0CON     REG32(SC_BASE + 0x080)
#define SC_PLL0CFG     REG32(SC_BASE + 0x084)
#define SC_PLL0STAT    REG32(SC_BASE + 0x088)
#define SC_PLL0FEED    REG32(SC_BASE + 0x08C)
#define SC_PCONP       REG32(SC_BASE + 0x0C4)
#define SC_CCLKCFG     REG32(SC_BASE + 0x104)
#define SC_CLKSRCSEL   REG32(SC_BASE + 0x10C)
#define SC_SCS         REG32(SC_BASE + 0x1A0)
#define SC_PCLKSEL0    REG32(SC_BASE + 0x1A8)
#define SC_PCLKSEL1    REG32(SC_BASE + 0x1AC)

#define PCONP_TIM1     (1u << 2)
#define PCONP_SPI      (1u << 8)
#define PCONP_SSP1     (1u << 10)
#define PCONP_GPIO     (1u << 15)
#define PCONP_SSP0     (1u << 21)
#define PCONP_TIM2     (1u << 22)

/* Pin connect block. */
#define PINCON_BASE    0x4002C000u
#define PINSEL(n)      REG32(PINCON_BASE + 4u * (n))
#define PINMODE(n)     REG32(PINCON_BASE + 0x40u + 4u * (n))

/* Fast GPIO. */
#define FIO_BASE(port) (0x2009C000u + 0x20u * (port))
#define FIO_DIR(port)  REG32(FIO_BASE(port) + 0x00)
#define FIO_PIN(port)  REG32(FIO_BASE(port) + 0x14)
#define FIO_SET(port)  REG32(FIO_BASE(port) + 0x18)
#define FIO_CLR(port)  REG32(FIO_BASE(port) + 0x1C)

/* GPIO interrupts (EINT3 vector). */
#define GPIOINT_BASE   0x40028080u
#define IO0_INT_CLR    REG32(GPIOINT_BASE + 0x0C)
#define IO0_INT_EN_F   REG32(GPIOINT_BASE + 0x14)

/* Legacy SPI. */
#define SPI_BASE       0x40020000u
#define S0SPCR         REG32(SPI_BASE + 0x00)
#define S0SPSR         REG32(SPI_BASE + 0x04)
#define S0SPDR         REG32(SPI_BASE + 0x08)
#define S0SPCCR        REG32(SPI_BASE + 0x0C)
#define SPCR_CPHA      (1u << 3)
#define SPCR_CPOL      (1u << 4)
#define SPCR_MSTR      (1u << 5)
#define SPSR_SPIF      (1u << 7)

/* SSP0 / SSP1. */
#define SSP0_BASE      0x40088000u
#define SSP1_BASE      0x40030000u
#define SSP_CR0(b)     REG32((b) + 0x00)
#define SSP_CR1(b)     REG32((b) + 0x04)
#define SSP_DR(b)      REG32((b) + 0x08)
#define SSP_SR(b)      REG32((b) + 0x0C)
#define SSP_CPSR(b)    REG32((b) + 0x10)
#define SSP_SR_TNF     (1u << 1)
#define SSP_SR_RNE     (1u << 2)
#define SSP_SR_BSY     (1u << 4)
#define SSP_CR1_SSE    (1u << 1)

/* Timers. */
#define TIM1_BASE      0x40008000u
#define TIM2_BASE      0x40090000u
#define TIM_IR(b)      REG32((b) + 0x00)
#define TIM_TCR(b)     REG32((b) + 0x04)
#define TIM_TC(b)      REG32((b) + 0x08)
#define TIM_PR(b)      REG32((b) + 0x0C)
#define TIM_MCR(b)     REG32((b) + 0x14)
#define TIM_CCR(b)     REG32((b) + 0x28)
#define TIM_CR0(b)     REG32((b) + 0x2C)
#define TIM_EMR(b)     REG32((b) + 0x3C)
#define TIM_IR_CR0     (1u << 4)

/* NVIC. */
#define NVIC_ISER      REG32(0xE000E100u)
#define NVIC_ICER      REG32(0xE000E180u)
#define NVIC_ICPR      REG32(0xE000E280u)
#define NVIC_IPR(n)    (*(volatile uint8_t *)(0xE000E400u + (n)))

#define IRQ_TIMER1     2
#define IRQ_EINT3      21

static inline uint32_t irq_save (void)
{
   uint32_t primask;
   __asm volatile ("mrs %0, primask\n cpsid i" : "=r" (primask) :: "memory");
   return primask;
}

static inline void irq_restore (uint32_t primask)
{
   __asm volatile ("msr primask, %0" :: "r" (primask) : "memory");
}

#endif /* LPC17XX_REGS_H */
